// The debugger's watch list: the names the operator watches (a variable, or one element
// `A[3]`), the `VARS` requests that read them (at most four names a request) and their last
// values from `EVT VAR`. Pure; the Debug pane (debug-pane.ts) asks and draws.

import type { VarValue } from './program-events';

/** Names `VARS` takes per request. */
export const VARS_PER_REQUEST = 4;

/** A variable (`COUNT`, `name$`) or one element of an array (`SLOTS[3]`). */
export function watchNameOk(name: string): boolean {
  return /^[A-Za-z_][A-Za-z0-9_]{0,31}\$?(\[\d{1,6}\])?$/.test(name);
}

/** What a watched name shows. */
export type WatchShown =
  | { kind: 'none' } // not read yet, or no program runs
  | { kind: 'value'; type: string; value: string }
  | { kind: 'unknown'; why: string };

export class WatchList {
  private list: string[] = [];
  private shown = new Map<string, WatchShown>();

  constructor(names: readonly string[] = []) {
    for (const n of names) this.add(n);
  }

  names(): readonly string[] {
    return this.list;
  }

  /** Add a name (trimmed); false when it is not one or is watched already. */
  add(raw: string): boolean {
    const name = raw.trim();
    if (!watchNameOk(name) || this.list.some((n) => n.toUpperCase() === name.toUpperCase())) return false;
    this.list.push(name);
    this.shown.set(name, { kind: 'none' });
    return true;
  }

  remove(name: string): void {
    this.list = this.list.filter((n) => n !== name);
    this.shown.delete(name);
  }

  /** The requests that read every watched name: `VARS a b c d`, … */
  requests(): string[] {
    const out: string[] = [];
    for (let i = 0; i < this.list.length; i += VARS_PER_REQUEST) {
      out.push(`VARS ${this.list.slice(i, i + VARS_PER_REQUEST).join(' ')}`);
    }
    return out;
  }

  /** Take the values a `VARS` reply gave (names compared ignoring case, as the language does). */
  apply(values: readonly VarValue[]): void {
    for (const v of values) {
      const name = this.list.find((n) => n.toUpperCase() === v.name.toUpperCase());
      if (name === undefined) continue;
      this.shown.set(name, v.known ? { kind: 'value', type: v.type, value: v.value } : { kind: 'unknown', why: v.why });
    }
  }

  /** Forget the values (the program ended). */
  clearValues(): void {
    for (const n of this.list) this.shown.set(n, { kind: 'none' });
  }

  value(name: string): WatchShown {
    return this.shown.get(name) ?? { kind: 'none' };
  }
}
