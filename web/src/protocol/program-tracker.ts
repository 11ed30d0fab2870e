// The running program as every part of the page sees it (the header's badge, the Control
// panel's disabled motions, the editor's debugger): `EVT PROGRAM` and the status stream's
// `line=`, kept in one `DebugState` (editor/debug-state.ts), reset when the connection comes or
// goes. No DOM.

import type { Bus, Unsubscribe } from './bus';
import { DebugState, type DebugView } from '../editor/debug-state';
import { parseProgramDetail, statusLine, type ProgramEvent } from '../editor/program-events';
import { Listeners } from './listeners';

/** Follows the bus; listeners hear `(view, stateChanged)` after each change. */
export class ProgramTracker {
  readonly state = new DebugState();
  private readonly listeners = new Listeners<[DebugView, boolean, ProgramEvent | null]>('program');
  private readonly unsubs: Unsubscribe[];

  constructor(bus: Pick<Bus, 'onEvent' | 'onConnection'>) {
    this.unsubs = [
      bus.onEvent((name, body) => {
        if (name === 'PROGRAM') {
          const e = parseProgramDetail(body);
          if (e && this.state.event(e)) this.listeners.emit(this.state.v, true, e);
        } else if (name === 'STATUS') {
          if (this.state.statusLine(statusLine(body))) this.listeners.emit(this.state.v, false, null);
        }
      }),
      bus.onConnection(() => {
        this.state.reset();
        this.listeners.emit(this.state.v, true, null);
      }),
    ];
  }

  get v(): DebugView {
    return this.state.v;
  }

  /**
   * `(view, stateChanged, event)`: `stateChanged` when the program's state changed (not only
   * its line); `event` the `EVT PROGRAM` that changed it, if one did.
   */
  onChange(cb: (v: DebugView, stateChanged: boolean, event: ProgramEvent | null) => void): Unsubscribe {
    return this.listeners.add(cb);
  }

  dispose(): void {
    for (const u of this.unsubs) u();
    this.listeners.clear();
  }
}

/**
 * What the header says of the program: `wafer_cycle running`, `wafer_cycle paused at
 * wafer_cycle:9`, `wafer_cycle waits for the operator: Load the cassette`; '' when none runs.
 */
export function programBadge(v: DebugView): string {
  const name = v.program ?? 'a program';
  const at = v.position ? ` at ${v.position.file}:${v.position.line}` : '';
  switch (v.state) {
    case 'none':
      return '';
    case 'running':
      return `${name} running`;
    case 'stepping':
      return `${name} stepping`;
    case 'paused':
      return `${name} paused${at}`;
    case 'waiting':
      return `${name} waits for the operator${v.prompt ? `: ${v.prompt}` : ''}`;
  }
}
