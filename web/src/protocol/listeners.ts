// Callbacks subscribed to one kind of change, for the page's stores and models.

import type { Unsubscribe } from './bus';

/**
 * The callbacks subscribed to one kind of change. `add` returns the unsubscribe; `emit`
 * calls every callback subscribed when it starts (one may unsubscribe itself meanwhile), each
 * guarded, so a failing callback is logged and does not keep the others from hearing it.
 */
export class Listeners<A extends unknown[]> {
  private readonly set = new Set<(...args: A) => void>();

  /** `what` names them in the log when one fails (`wafer map`, `stations`, …). */
  constructor(private readonly what: string) {}

  add(cb: (...args: A) => void): Unsubscribe {
    this.set.add(cb);
    return () => {
      this.set.delete(cb);
    };
  }

  emit(...args: A): void {
    for (const cb of [...this.set]) {
      try {
        cb(...args);
      } catch (e) {
        console.error(`wrc: ${this.what} listener failed`, e);
      }
    }
  }

  clear(): void {
    this.set.clear();
  }
}
