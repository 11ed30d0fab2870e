// What a power loss left uncertain (docs/protocol.md, "Stations and wafers"; docs/gui.md,
// "Recovery"), as the controller reports it, and the `RecoveryStore` that keeps it up to
// date for the recovery panel.
//
// - `RECOVERY` (read-only) is answered with `EVT RECOVERY <line>` lines to the requester, then
//   `ACK <id> uncertain=<n> inside=<station|-> journal_…=…` (what the journal has cost the
//   transfers; not used here). The lines:
//     `note <what happened>`                 the journaled step of the interrupted transfer
//     `hand x=… y=… z=… yaw=… inside=<station|->`   where the hand is, and the station it
//                                            may be inside
//     `uncertain <place> <wafer>`            one per uncertain place: `LP2.1`, `hand`, `hand.B`
//     `next <actions>`                       the controller's suggestion, comma-separated
// - After a start-up that found something uncertain, the controller broadcasts the same lines
//   to every connection; after each recovery action it broadcasts one line saying what it did
//   (`retracted out of LP2`, `SENSE: W1 is on the hand (vacuum sensor)`, `confirmed …`).
// - Alarm 216 (`EVT ERROR 216 …`) is raised at start-up when anything is uncertain or the hand
//   may be inside a station.
//
// The store asks `RECOVERY` after each connection, on every `EVT RECOVERY`, on `EVT ERROR 216`,
// on `EVT WAFER` while anything is (or was) uncertain, and whenever the panel asks (after each
// action's reply). Parsing never throws: a malformed line is left out and reported in `bad`.

import type { Bus, FirstReply, Unsubscribe } from '../protocol/bus';
import { Listeners } from '../protocol/listeners';
import type { Blade } from './wafers';

/** A place a wafer may be in: a station's slot, or a blade. */
export type RecoveryPlace = { kind: 'slot'; station: string; slot: number } | { kind: 'blade'; blade: Blade };

/** `uncertain <place> <wafer>`: the wafer may be there, or not. */
export interface UncertainPlace {
  place: RecoveryPlace;
  /** `W1`. */
  wafer: string;
}

/** `hand x=… y=… z=… yaw=… inside=…`: where the hand is [mm, deg]. */
export interface HandPosition {
  x: number;
  y: number;
  z: number;
  yaw: number;
  /** The station the hand may be inside, or null when it is outside every station. */
  inside: string | null;
}

/** One `EVT RECOVERY` line. */
export type RecoveryLine =
  | { kind: 'note'; text: string }
  | { kind: 'hand'; hand: HandPosition }
  | { kind: 'uncertain'; place: RecoveryPlace; wafer: string }
  | { kind: 'next'; items: string[] }
  /** What a recovery action did (`retracted out of LP2`, `SENSE: …`, `confirmed …`). */
  | { kind: 'action'; text: string };

/** The controller's answer to `RECOVERY`. */
export interface RecoveryReport {
  /** What happened (the interrupted transfer and its journaled step); null when nothing is noted. */
  note: string | null;
  /** Where the hand is; null when the reply had no `hand` line. */
  hand: HandPosition | null;
  /** The station the hand may be inside (the ACK's `inside=`, else the hand line's), or null. */
  inside: string | null;
  /** Every uncertain place, in the controller's order. */
  uncertain: UncertainPlace[];
  /** The controller's suggested next actions, as it wrote them (`MAP LP2`, `or CONFIRM …`). */
  next: string[];
  /** The ACK's `uncertain=<n>` (null when absent). */
  count: number | null;
}

/** `LP2.1`, `hand`, `hand.B` (as the controller writes a place). */
export function placeText(p: RecoveryPlace): string {
  if (p.kind === 'slot') return `${p.station}.${p.slot}`;
  return p.blade === 'B' ? 'hand.B' : 'hand';
}

/** `LP2 slot 1`, `the hand`, `blade B` (as an operator reads it). */
export function placeWords(p: RecoveryPlace): string {
  if (p.kind === 'slot') return `${p.station} slot ${p.slot}`;
  return p.blade === 'B' ? 'blade B' : 'the hand';
}

/** The same place? */
export function samePlace(a: RecoveryPlace, b: RecoveryPlace): boolean {
  if (a.kind === 'slot') return b.kind === 'slot' && a.station === b.station && a.slot === b.slot;
  return b.kind === 'blade' && a.blade === b.blade;
}

/** A place token: `LP2.1`, `hand`, `hand.B` (`hand.A` is the hand too); null when malformed. */
export function parsePlace(tok: string): RecoveryPlace | null {
  if (tok === 'hand' || tok === 'hand.A') return { kind: 'blade', blade: 'A' };
  if (tok === 'hand.B') return { kind: 'blade', blade: 'B' };
  const m = /^([^\s=:,.]+)\.(\d{1,3})$/.exec(tok);
  if (!m) return null;
  const slot = Number(m[2]);
  return slot >= 1 ? { kind: 'slot', station: m[1], slot } : null;
}

/** `key=value` words of a line. */
function fields(words: readonly string[]): Record<string, string> {
  const f: Record<string, string> = {};
  for (const w of words) {
    const eq = w.indexOf('=');
    if (eq > 0) f[w.slice(0, eq)] = w.slice(eq + 1);
  }
  return f;
}

/**
 * One `EVT RECOVERY` body (a leading `RECOVERY ` is skipped). Any line that is not one of the
 * report's four is what an action did (`action`). Null for a malformed `hand` or `uncertain`
 * line.
 */
export function parseRecoveryLine(text: string): RecoveryLine | null {
  if (typeof text !== 'string') return null;
  const t = text.trim().replace(/^RECOVERY(?:[ \t]+|$)/, '');
  const sp = t.search(/[ \t]/);
  const head = sp < 0 ? t : t.slice(0, sp);
  const rest = sp < 0 ? '' : t.slice(sp + 1).trim();
  switch (head) {
    case 'note':
      return { kind: 'note', text: rest };
    case 'hand': {
      const f = fields(rest.split(/[ \t]+/));
      const n = (k: string): number => (f[k] === undefined || f[k] === '' ? NaN : Number(f[k]));
      const [x, y, z, yaw] = [n('x'), n('y'), n('z'), n('yaw')];
      if (![x, y, z, yaw].every(Number.isFinite) || f.inside === undefined || f.inside === '') return null;
      return { kind: 'hand', hand: { x, y, z, yaw, inside: f.inside === '-' ? null : f.inside } };
    }
    case 'uncertain': {
      const w = rest.split(/[ \t]+/);
      if (w.length !== 2) return null;
      const place = parsePlace(w[0]);
      const m = /^[Ww](\d{1,10})$/.exec(w[1]);
      if (!place || !m) return null;
      return { kind: 'uncertain', place, wafer: `W${Number(m[1])}` };
    }
    case 'next':
      return {
        kind: 'next',
        items: rest
          .split(/,[ \t]*/)
          .map((s) => s.trim())
          .filter((s) => s !== ''),
      };
    default:
      return { kind: 'action', text: t };
  }
}

/** An empty report (nothing uncertain, the hand outside, nothing noted). */
export function emptyReport(): RecoveryReport {
  return { note: null, hand: null, inside: null, uncertain: [], next: [], count: null };
}

/**
 * The report from a `RECOVERY` reply: its ACK line (`ACK 7 uncertain=2 inside=-`) and the
 * event lines collected before it (without `EVT `; only `RECOVERY …` lines are used). Lines
 * another connection's action or a start-up broadcast added before the reply are left out:
 * the reply is the last `hand` line with the `note` right before it and the `uncertain` and
 * `next` lines after it. `bad` lists malformed lines, and says when the count of `uncertain`
 * lines is not the ACK's.
 */
export function recoveryFromReply(ackLine: string, events: readonly string[]): { report: RecoveryReport; bad: string[] } {
  const bad: string[] = [];
  const lines: RecoveryLine[] = [];
  for (const e of events) {
    if (!/^RECOVERY(?:[ \t]|$)/.test(e)) continue;
    const l = parseRecoveryLine(e);
    if (l) lines.push(l);
    else bad.push(e);
  }
  let start = 0;
  for (let i = lines.length - 1; i >= 0; i--) {
    if (lines[i].kind === 'hand') {
      start = i > 0 && lines[i - 1].kind === 'note' ? i - 1 : i;
      break;
    }
  }
  const report = emptyReport();
  for (const l of lines.slice(start)) {
    switch (l.kind) {
      case 'note':
        report.note = l.text;
        break;
      case 'hand':
        report.hand = l.hand;
        break;
      case 'uncertain':
        report.uncertain.push({ place: l.place, wafer: l.wafer });
        break;
      case 'next':
        report.next = l.items;
        break;
      case 'action':
        break;
    }
  }
  const body = (typeof ackLine === 'string' ? ackLine : '').replace(/\*[0-9A-Fa-f]{2}\s*$/, '');
  const f = fields(body.trim().split(/[ \t]+/));
  const count = f.uncertain !== undefined && /^\d+$/.test(f.uncertain) ? Number(f.uncertain) : null;
  report.count = count;
  const inside = f.inside ?? (report.hand ? (report.hand.inside ?? '-') : '-');
  report.inside = inside === '-' || inside === '' ? null : inside;
  if (count !== null && count !== report.uncertain.length) {
    bad.push(`uncertain=${count} but ${report.uncertain.length} uncertain line${report.uncertain.length === 1 ? '' : 's'} came`);
  }
  return { report, bad };
}

/** Whether the report asks for recovery: anything uncertain, or the hand inside a station. */
export function recoveryNeeded(r: RecoveryReport | null): boolean {
  return r !== null && (r.uncertain.length > 0 || r.inside !== null);
}

/** The distinct wafers of the uncertain places, in order (`W1`). */
export function uncertainWafers(r: RecoveryReport): string[] {
  return [...new Set(r.uncertain.map((u) => u.wafer))];
}

// ---------------------------------------------------------------------------------------------
// The store

export interface RecoveryState {
  /**
   * Whether the controller answers `RECOVERY`: null before the first reply, false when it
   * refused it (no cell configured, or an older controller), true otherwise.
   */
  available: boolean | null;
  /** The last report (null before the first). */
  report: RecoveryReport | null;
  /** The refusal's code and text when `available` is false. */
  refusal: string;
  /** What the recovery actions did (their `EVT RECOVERY` lines), newest last, at most 10. */
  done: string[];
  /** Malformed lines of the last reply. */
  bad: string[];
}

export interface RecoveryStore {
  state(): RecoveryState;
  /** Called with the new state after every change (not at once). */
  onChange(cb: (s: RecoveryState) => void): Unsubscribe;
  /**
   * Ask `RECOVERY` again (resolves when the reply has been handled; never rejects). Asked while
   * a request is on its way, it asks once more after that reply.
   */
  refresh(): Promise<void>;
  dispose(): void;
}

const MAX_DONE = 10;

/** Keep the recovery report of the controller behind `bus` (see the module comment). */
export function createRecoveryStore(
  bus: Bus,
  warn: (msg: string) => void = (m) => console.warn(`wrc: ${m}`),
): RecoveryStore {
  let st: RecoveryState = { available: null, report: null, refusal: '', done: [], bad: [] };
  const listeners = new Listeners<[RecoveryState]>('recovery');
  let disposed = false;
  /** A loop of `RECOVERY` requests runs (`current`); `again`: ask once more after this reply. */
  let busy = false;
  let again = false;
  let current: Promise<void> = Promise.resolve();
  /** A `RECOVERY` request waits for its ACK: the report lines that come now are its own. */
  let asking = false;

  function set(next: RecoveryState): void {
    st = next;
    listeners.emit(st);
  }

  function take(first: FirstReply, events: string[]): void {
    if (first.kind === 'NAK') {
      set({ ...st, available: false, report: null, refusal: `${first.code} ${first.text}`, bad: [] });
      return;
    }
    const { report, bad } = recoveryFromReply(first.line, events);
    for (const b of bad) warn(`RECOVERY: ignored ${JSON.stringify(b)}`);
    set({ ...st, available: true, report, refusal: '', bad });
  }

  async function loop(): Promise<void> {
    try {
      while (again) {
        again = false;
        if (disposed || !bus.connected()) return;
        asking = true;
        try {
          const r = await bus.request('RECOVERY');
          if (!disposed) take(r.first, r.events);
        } catch {
          return; // lost connection or timeout: asked again on the next connection
        } finally {
          asking = false;
        }
      }
    } finally {
      busy = false;
    }
  }

  function refresh(): Promise<void> {
    again = true;
    if (!busy) {
      busy = true;
      current = loop();
    }
    return current;
  }

  function event(name: string, body: string): void {
    if (disposed) return;
    if (name === 'RECOVERY') {
      const l = parseRecoveryLine(body);
      if (l?.kind === 'action') set({ ...st, done: [...st.done, l.text].slice(-MAX_DONE) });
      // The report's own lines (the reply, or a start-up's broadcast of the same) do not ask
      // again while a reply is on its way: asking on them would never end.
      else if (asking) return;
      void refresh();
    } else if (name === 'ERROR') {
      if (/^216(?:\s|$)/.test(body.trim())) void refresh();
    } else if (name === 'WAFER') {
      // A change of the map may settle (or leave) an uncertain place.
      if (recoveryNeeded(st.report) || /W\d+\?/.test(body)) void refresh();
    }
  }

  const unsubs: Unsubscribe[] = [
    bus.onConnection((up) => {
      if (up) void refresh();
    }),
    bus.onEvent(event),
  ];
  void refresh();

  return {
    state: () => st,
    onChange: (cb) => listeners.add(cb),
    refresh,
    dispose() {
      disposed = true;
      listeners.clear();
      for (const u of unsubs) u();
    },
  };
}
