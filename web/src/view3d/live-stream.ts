// The live robot for the 3D view: the simulator datagrams as they arrive (counted for the
// overlay's rate and lost datagrams), of which the view draws only the newest, once per frame,
// however many came since the last one.

import type { Bus, SimSample, Unsubscribe } from '../protocol/bus';
import { StreamStats } from '../protocol/stream';

/** The live datagrams the 3D view follows, and their statistics. */
export class LiveStream {
  /** The newest sample received (null: none yet). */
  latest: SimSample | null = null;
  /** The sample the view drew last (null: none yet, or to be drawn again). */
  applied: SimSample | null = null;
  /** Whether the bus is connected. */
  connected: boolean;
  readonly stats = new StreamStats();
  private readonly unsubs: Unsubscribe[];

  /** Follow `bus`; `onConnection` is called after the connection came or went. */
  constructor(bus: Pick<Bus, 'connected' | 'onSample' | 'onConnection'>, onConnection: () => void) {
    this.connected = bus.connected();
    this.unsubs = [
      bus.onSample((s) => {
        this.latest = s;
        this.stats.push(s, performance.now());
      }),
      bus.onConnection((c) => {
        this.connected = c;
        onConnection();
      }),
    ];
  }

  /** The newest sample when the view has not drawn it yet, now counted as drawn; else null. */
  takeNew(): SimSample | null {
    if (this.latest === this.applied || this.latest === null) return null;
    this.applied = this.latest;
    return this.applied;
  }

  /** Have the next `takeNew` return the newest sample again (after a recorded frame). */
  redraw(): void {
    this.applied = null;
  }

  dispose(): void {
    for (const u of this.unsubs) u();
  }
}
