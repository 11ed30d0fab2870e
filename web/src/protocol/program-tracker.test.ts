import { describe, expect, it } from 'vitest';
import type { Bus } from './bus';
import { ProgramTracker, programBadge } from './program-tracker';

function fakeBus() {
  let event: (n: string, b: string, l: string) => void = () => undefined;
  let conn: (up: boolean, d: string) => void = () => undefined;
  const bus: Pick<Bus, 'onEvent' | 'onConnection'> = {
    onEvent: (cb) => ((event = cb), () => undefined),
    onConnection: (cb) => ((conn = cb), () => undefined),
  };
  return { bus, evt: (name: string, body: string) => event(name, body, ''), conn: (up: boolean) => conn(up, '') };
}

describe('ProgramTracker and the header badge', () => {
  it('shows a program running, paused at a breakpoint, waiting for the operator, and nothing once it ended', () => {
    const f = fakeBus();
    const t = new ProgramTracker(f.bus);
    const seen: string[] = [];
    t.onChange((v) => seen.push(programBadge(v)));
    f.evt('PROGRAM', 'wafer_cycle RUNNING files=wafer_cycle,cell_lib');
    expect(programBadge(t.v)).toBe('wafer_cycle running');
    f.evt('PROGRAM', 'wafer_cycle PAUSED wafer_cycle:9');
    expect(programBadge(t.v)).toBe('wafer_cycle paused at wafer_cycle:9');
    f.evt('PROGRAM', 'wafer_cycle WAITING wafer_cycle:15 Load the cassette');
    expect(programBadge(t.v)).toBe('wafer_cycle waits for the operator: Load the cassette');
    f.evt('PROGRAM', 'wafer_cycle ENDED');
    expect(programBadge(t.v)).toBe('');
    expect(seen).toHaveLength(4);
  });

  it('a program started before the page connected shows from the status stream; a reconnection forgets it', () => {
    const f = fakeBus();
    const t = new ProgramTracker(f.bus);
    f.evt('STATUS', 'state=MOVING homed=1 speed=50 owner=gui0 err=0 j=1,2,3,4 x=1 y=2 z=3 yaw=4 line=0:12');
    expect(programBadge(t.v)).toBe('a program running');
    f.conn(false);
    expect(programBadge(t.v)).toBe('');
  });
});
