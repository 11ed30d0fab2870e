// What the status line under the header shows until the operator has read it: refusals
// (`NAK`), alarms (`EVT ERROR`, `ABS`), deliberate stops (STOP, E-STOP: 200-202, told as what
// they are, not as faults), notices (a jog shortened before an obstacle, a PTP routed
// through the travel posture, an output forced) and what is still under way (a RESET that
// waits for the arm to stand still). Pure: the classification of each line is a function,
// the board a store with an injected clock; the DOM is `panels/status-line.ts`.

import type { FinalReply, FirstReply, Unsubscribe } from './bus';
import { Listeners } from './listeners';
import { verbOf } from './protocol';

/**
 * `alarm`: the robot stopped on a fault (red). `refusal`: a request refused, nothing moved
 * (red-orange). `stop`: a stop someone asked for (amber). `notice`: worth knowing (blue).
 * `waiting`: under way, replaced when it ends.
 */
export type NoticeLevel = 'alarm' | 'refusal' | 'stop' | 'notice' | 'waiting';

/** What a notice says; the board adds its id, time and count. */
export interface NoticeSpec {
  level: NoticeLevel;
  /** A short tag before the text: `NAK 111`, `ERROR 203`, `E-STOP`, `JOG`. */
  tag: string;
  /** The sentence for the operator. */
  text: string;
  /**
   * Notices with the same key within `COALESCE_MS` are one (an E-stop's `ABS … 201` and its
   * `EVT ERROR 201`): the newer text replaces the older, the count goes up.
   */
  key: string;
}

export interface Notice extends NoticeSpec {
  id: number;
  /** When it came (the board's clock) [ms]. */
  at: number;
  /** How many times it came (coalesced). */
  count: number;
}

/** Codes of stops someone asked for: STOP or ABORT (200), ESTOP (201), the E-stop input (202). */
export const STOP_CODES: ReadonlySet<number> = new Set([200, 201, 202]);

/** Within this time a notice with the same key is counted, not added [ms]. */
export const COALESCE_MS = 3000;

/** What a deliberate stop is called: `STOP`, `E-STOP`, `E-STOP input`. */
function stopTag(code: number): string {
  return code === 200 ? 'STOP' : code === 202 ? 'E-STOP input' : 'E-STOP';
}

/** The sentence after a deliberate stop: what it was and what comes next. */
function stopText(code: number, what: string): string {
  if (code === 200) return `Stopped as asked (${what}); no RESET needed.`;
  if (code === 202) return `The E-stop input opened (${what}): release the E-stop, then RESET.`;
  return `Emergency stop (${what}): RESET once the cell is safe.`;
}

/** `ACK …` notices: a jog shortened before an obstacle, a PTP routed through the travel posture. */
function ackNotice(request: string, fields: Record<string, string>): NoticeSpec | null {
  const verb = verbOf(request);
  if (fields.limited) {
    return {
      level: 'notice',
      tag: verb,
      text: `${request}: shortened to stop before ${fields.limited}.`,
      key: `limited:${request}`,
    };
  }
  if (fields.route === 'travel') {
    return {
      level: 'notice',
      tag: verb,
      text: `${request}: routed through the travel posture (the direct way would touch the cell).`,
      key: `route:${request}`,
    };
  }
  return null;
}

/**
 * The notice for the first reply to `request`, or null: a `NAK` is a refusal (a RESET the
 * controller refuses while a stop still brakes says so, rather than an error); an `ACK`
 * that says a jog was shortened or a PTP routed is a notice.
 */
export function noticeForFirst(request: string, first: FirstReply): NoticeSpec | null {
  const verb = verbOf(request);
  if (first.kind === 'ACK') return ackNotice(request, first.fields);
  if (verb === 'RESET' && first.code === 121) {
    return {
      level: 'waiting',
      tag: 'RESET',
      text: 'The stop is still under way: press Reset again once the arm stands still.',
      key: 'reset',
    };
  }
  const obstacle = first.code === 117 ? ' (it would touch the cell)' : '';
  return {
    level: 'refusal',
    tag: `NAK ${first.code}`,
    text: `${request} refused${obstacle}: ${first.text}`,
    key: `nak:${first.code}:${verb}`,
  };
}

/** The notice for the end of `request`: an `ABS` (a stop someone asked for, or an alarm); an `INF` is none. */
export function noticeForFinal(request: string, final: FinalReply): NoticeSpec | null {
  if (final.kind === 'INF') return null;
  const verb = verbOf(request);
  if (STOP_CODES.has(final.code)) {
    return { level: 'stop', tag: stopTag(final.code), text: stopText(final.code, `${verb} ended: ${final.text}`), key: `code:${final.code}` };
  }
  return { level: 'alarm', tag: `ABS ${final.code}`, text: `${request} ended: ${final.text}`, key: `code:${final.code}` };
}

/**
 * The notice for an event from any connection, or null: `EVT ERROR` (an alarm, or a stop
 * someone asked for), `EVT RECOVERY forced …` (an output switched with FORCE).
 */
export function noticeForEvent(name: string, body: string): NoticeSpec | null {
  if (name === 'ERROR') {
    const m = /^\s*(\d+)\s*(.*)$/.exec(body);
    if (!m) return null;
    const code = Number(m[1]);
    const text = m[2].trim();
    if (STOP_CODES.has(code)) return { level: 'stop', tag: stopTag(code), text: stopText(code, text || `code ${code}`), key: `code:${code}` };
    return { level: 'alarm', tag: `ERROR ${code}`, text: text || `alarm ${code}`, key: `code:${code}` };
  }
  if (name === 'RECOVERY') {
    const m = /^\s*forced\s+(.*)$/i.exec(body);
    if (!m) return null;
    return { level: 'notice', tag: 'FORCED', text: m[1].trim(), key: `forced:${m[1].trim()}` };
  }
  return null;
}

/** The notices not yet dismissed, newest first. */
export class NoticeBoard {
  /** At most this many are kept (the oldest go). */
  static readonly MAX = 50;
  private list: Notice[] = [];
  private nextId = 1;
  private readonly listeners = new Listeners<[readonly Notice[]]>('notices');

  /** `now`: the clock [ms] (tests pass a fake). */
  constructor(private readonly now: () => number = () => Date.now()) {}

  /** Add `spec`, or count it on an unread notice of the same key from the last `COALESCE_MS`. Returns its id. */
  add(spec: NoticeSpec): number {
    const t = this.now();
    const same = this.list.find((n) => n.key === spec.key && t - n.at <= COALESCE_MS);
    if (same) {
      // An alarm's text may be fuller in the event than in the ABS (or the other way): the
      // newer replaces it; a stop never turns an alarm into a stop.
      Object.assign(same, { ...spec, level: rank(spec.level) >= rank(same.level) ? spec.level : same.level });
      same.count++;
      same.at = t;
      this.list = [same, ...this.list.filter((n) => n !== same)];
      this.listeners.emit(this.list);
      return same.id;
    }
    const n: Notice = { ...spec, id: this.nextId++, at: t, count: 1 };
    this.list = [n, ...this.list].slice(0, NoticeBoard.MAX);
    this.listeners.emit(this.list);
    return n.id;
  }

  /** Replace notice `id` by `spec` (a waiting RESET that got its answer); added if it is gone. */
  replace(id: number, spec: NoticeSpec | null): void {
    const had = this.list.some((n) => n.id === id);
    this.list = this.list.filter((n) => n.id !== id);
    if (spec) this.add(spec);
    else if (had) this.listeners.emit(this.list);
  }

  dismiss(id: number): void {
    const before = this.list.length;
    this.list = this.list.filter((n) => n.id !== id);
    if (this.list.length !== before) this.listeners.emit(this.list);
  }

  /** Dismiss every notice with key `key` (a waiting RESET once a RESET was accepted). */
  dismissKey(key: string): void {
    const before = this.list.length;
    this.list = this.list.filter((n) => n.key !== key);
    if (this.list.length !== before) this.listeners.emit(this.list);
  }

  dismissAll(): void {
    if (this.list.length === 0) return;
    this.list = [];
    this.listeners.emit(this.list);
  }

  /** The notices, newest first. */
  notices(): readonly Notice[] {
    return this.list;
  }

  onChange(cb: (list: readonly Notice[]) => void): Unsubscribe {
    return this.listeners.add(cb);
  }
}

function rank(l: NoticeLevel): number {
  return { waiting: 0, notice: 1, stop: 2, refusal: 3, alarm: 4 }[l];
}
