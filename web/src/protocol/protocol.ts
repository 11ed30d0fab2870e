// Pure parsing and formatting of the controller's line protocol (docs/protocol.md) for the
// browser: no DOM, no sockets, so every function here is unit-tested on plain strings.

import type { AxisInfo, FirstReply, RobotInfo, RobotState, SignalInfo } from './bus';

/** One line from `wrc ui`, classified. */
export type Line =
  | { kind: 'ACK'; id: number | null; fields: Record<string, string>; line: string }
  | { kind: 'NAK'; id: number | null; code: number; text: string; line: string }
  | { kind: 'INF'; id: number | null; fields: Record<string, string>; line: string }
  | { kind: 'ABS'; id: number | null; code: number; text: string; line: string }
  | { kind: 'EVT'; name: string; body: string; line: string }
  | { kind: 'OTHER'; line: string };

const DIGITS = /^[0-9]+$/;

/** Words separated by runs of blanks (spaces and tabs), as the protocol splits them. */
function words(s: string): string[] {
  return s.split(/[ \t]+/).filter((w) => w.length > 0);
}

/** Strip a serial checksum (`*HH` at the end) if present; wrc ui never sends one, but be lenient. */
function stripChecksum(s: string): string {
  return s.replace(/\*[0-9A-Fa-f]{2}\s*$/, '');
}

/**
 * `key=value` pairs of a reply or event body. Words without `=` are ignored; a later key
 * replaces an earlier one.
 */
export function parseFields(body: string): Record<string, string> {
  const out: Record<string, string> = {};
  for (const w of words(body)) {
    const eq = w.indexOf('=');
    if (eq > 0) out[w.slice(0, eq)] = w.slice(eq + 1);
  }
  return out;
}

/** Split `[<id>] <code> <text>` of a NAK/ABS (the text never starts with a digit). */
function idCodeText(rest: string[]): { id: number | null; code: number; text: string } {
  if (rest.length >= 2 && DIGITS.test(rest[0]) && DIGITS.test(rest[1])) {
    return { id: Number(rest[0]), code: Number(rest[1]), text: rest.slice(2).join(' ') };
  }
  if (rest.length >= 1 && DIGITS.test(rest[0])) {
    return { id: null, code: Number(rest[0]), text: rest.slice(1).join(' ') };
  }
  return { id: null, code: 0, text: rest.join(' ') };
}

/** Split `[<id>][ key=value…]` of an ACK/INF. */
function idFields(rest: string[]): { id: number | null; fields: Record<string, string> } {
  if (rest.length >= 1 && DIGITS.test(rest[0])) {
    return { id: Number(rest[0]), fields: parseFields(rest.slice(1).join(' ')) };
  }
  return { id: null, fields: parseFields(rest.join(' ')) };
}

/** Classify one line (without its LF) from the controller or from `wrc ui`. */
export function parseLine(raw: string): Line {
  const line = raw.replace(/\r?\n$/, '').replace(/\r$/, '');
  const ws = words(line);
  const head = (ws[0] ?? '').toUpperCase();
  switch (head) {
    case 'ACK':
    case 'INF': {
      const { id, fields } = idFields(words(stripChecksum(line)).slice(1));
      return { kind: head, id, fields, line };
    }
    case 'NAK':
    case 'ABS': {
      const { id, code, text } = idCodeText(words(stripChecksum(line)).slice(1));
      return { kind: head, id, code, text, line };
    }
    case 'EVT': {
      const m = /^\s*EVT[ \t]+(\S+)[ \t]*(.*)$/i.exec(line);
      if (!m) return { kind: 'EVT', name: '', body: '', line };
      return { kind: 'EVT', name: m[1].toUpperCase(), body: m[2], line };
    }
    default:
      return { kind: 'OTHER', line };
  }
}

function num(v: string | undefined, fallback = 0): number {
  if (v === undefined || v === '') return fallback;
  const n = Number(v);
  return Number.isFinite(n) ? n : fallback;
}

/** `EVT AXIS 1 name=j1 role=shoulder unit=deg ppu=1000 min=-180 max=180 home=-75` (body after `AXIS`). */
export function parseAxis(body: string): AxisInfo | null {
  const ws = words(body);
  if (ws.length === 0 || !DIGITS.test(ws[0])) return null;
  const f = parseFields(ws.slice(1).join(' '));
  return {
    index: Number(ws[0]),
    name: f.name ?? `j${ws[0]}`,
    role: f.role ?? 'auxiliary',
    unit: f.unit ?? 'deg',
    ppu: num(f.ppu, 1),
    min: num(f.min),
    max: num(f.max),
    home: num(f.home),
  };
}

/**
 * Blade B's height offset from `blade_b=<mm>` of the `ROBOT` reply: null when absent (a
 * single-hand robot) or not a number, so that a garbled field never draws a blade that is
 * not there.
 */
function bladeOffset(v: string | undefined): number | null {
  if (v === undefined || v.trim() === '') return null;
  const n = Number(v);
  return Number.isFinite(n) ? n : null;
}

/**
 * `EVT SIGNAL <in|out> <n> <guarded|-> <name…>` (the body after `SIGNAL`): `out 0 guarded
 * vacuum valve`, `in 14 - interlock LP1 LP2`. Null for anything else (a signal number beyond
 * 31, another direction or mark, no name); the name is the rest of the line, blanks kept
 * between its words.
 */
export function parseSignal(body: string): SignalInfo | null {
  if (typeof body !== 'string') return null;
  const m = /^\s*(in|out)[ \t]+(\d{1,2})[ \t]+(guarded|-)[ \t]+(\S.*?)\s*$/i.exec(body);
  if (!m) return null;
  const n = Number(m[2]);
  if (n > 31) return null;
  return { dir: m[1].toLowerCase() as 'in' | 'out', n, guarded: m[3].toLowerCase() === 'guarded', name: m[4] };
}

/**
 * The robot from the `ROBOT` reply: its `ACK` fields and the `EVT AXIS` and `EVT SIGNAL` lines
 * collected before it (given as event lines without `EVT `, e.g. `AXIS 1 name=j1 …`; other
 * events are skipped, as are malformed lines; a signal named twice keeps its last name).
 */
export function robotFromReply(fields: Record<string, string>, events: string[]): RobotInfo {
  const axes: AxisInfo[] = [];
  const signals = new Map<string, SignalInfo>();
  for (const e of events) {
    const sig = /^SIGNAL[ \t]+(.*)$/i.exec(e);
    if (sig) {
      const s = parseSignal(sig[1]);
      if (s) signals.set(`${s.dir}${s.n}`, s);
      continue;
    }
    const m = /^AXIS[ \t]+(.*)$/i.exec(e);
    if (!m) continue;
    const a = parseAxis(m[1]);
    if (a) axes.push(a);
  }
  axes.sort((a, b) => a.index - b.index);
  return {
    name: fields.name ?? 'robot',
    link1: num(fields.link1),
    link2: num(fields.link2),
    hand: num(fields.hand),
    bladeB: bladeOffset(fields.blade_b),
    periodMs: num(fields.period_ms, 10),
    inputs: num(fields.inputs, 32),
    outputs: num(fields.outputs, 32),
    axes,
    signals: [...signals.values()].sort((a, b) => (a.dir === b.dir ? a.n - b.n : a.dir === 'in' ? -1 : 1)),
  };
}

const STATES: readonly RobotState[] = ['IDLE', 'MOVING', 'STOPPING', 'HELD', 'ERROR', 'ESTOP'];

/** A controller state name, or null when it is none of the six. */
export function parseState(s: string | undefined): RobotState | null {
  const u = (s ?? '').trim().toUpperCase();
  return (STATES as readonly string[]).includes(u) ? (u as RobotState) : null;
}

/** The fields of `STATUS`, `WHERE` and `EVT STATUS` (each present only if the line had it). */
export interface Status {
  state?: RobotState;
  homed?: boolean;
  speed?: number;
  owner?: string;
  err?: number;
  joints?: number[];
  x?: number;
  y?: number;
  z?: number;
  yaw?: number;
}

/**
 * `state=MOVING homed=1 speed=50 owner=gui0 err=0 j=10,45.5,-45.5,5 x=… y=… z=… yaw=…`: the
 * body of `EVT STATUS`, or the fields of a `STATUS` / `WHERE` ACK.
 */
export function parseStatus(body: string | Record<string, string>): Status {
  const f = typeof body === 'string' ? parseFields(body) : body;
  const s: Status = {};
  const st = parseState(f.state);
  if (st) s.state = st;
  if (f.homed !== undefined) s.homed = f.homed === '1';
  if (f.speed !== undefined) s.speed = num(f.speed);
  if (f.owner !== undefined) s.owner = f.owner;
  if (f.err !== undefined) s.err = num(f.err);
  if (f.j !== undefined && f.j !== '') s.joints = f.j.split(',').map((v) => num(v));
  for (const k of ['x', 'y', 'z', 'yaw'] as const) if (f[k] !== undefined) s[k] = num(f[k]);
  return s;
}

/** One compiler diagnostic from `EVT DIAG <file>:<line>:<col>: <severity>: <message>`. */
export interface Diag {
  file: string;
  line: number;
  col: number;
  severity: 'error' | 'warning' | 'info';
  message: string;
}

/** The body of `EVT DIAG` (or the event line without `EVT `: a leading `DIAG ` is skipped). */
export function parseDiag(body: string): Diag | null {
  const b = body.replace(/^\s*DIAG[ \t]+/i, '');
  const m = /^(.*?):(\d+):(\d+):[ \t]*([A-Za-z]+):[ \t]*(.*)$/.exec(b.trim());
  if (!m) return null;
  const sev = m[4].toLowerCase();
  return {
    file: m[1],
    line: Number(m[2]),
    col: Number(m[3]),
    severity: sev === 'error' ? 'error' : sev === 'warning' ? 'warning' : 'info',
    message: m[5],
  };
}

/** Diagnostics among collected event lines (without `EVT `). */
export function diagsFromEvents(events: string[]): Diag[] {
  const out: Diag[] = [];
  for (const e of events) {
    if (!/^DIAG[ \t]/i.test(e)) continue;
    const d = parseDiag(e);
    if (d) out.push(d);
  }
  return out;
}

/** `<name> line <n>: <what>` in an ABS text of a program: the source line, or null. */
export function programAbsLine(text: string): number | null {
  const m = /\bline (\d+)\b/.exec(text);
  return m ? Number(m[1]) : null;
}

/**
 * What an `ACK`/`INF` line says after its reply word and id (`INF 7 LP1 1111` → `LP1 1111`,
 * `INF 3 W3` → `W3`, `INF 3` → ''), without a checksum.
 */
export function replyRest(line: string): string {
  const ws = words(stripChecksum(line));
  const i = ws.length > 1 && DIGITS.test(ws[1]) ? 2 : 1;
  return ws.slice(i).join(' ');
}

/** `ACK … in=<hex> out=<hex>` of `IO`. */
export function parseIo(fields: Record<string, string>): { inputs: number; outputs: number } | null {
  if (fields.in === undefined || fields.out === undefined) return null;
  const i = parseInt(fields.in, 16);
  const o = parseInt(fields.out, 16);
  if (!Number.isFinite(i) || !Number.isFinite(o)) return null;
  return { inputs: i >>> 0, outputs: o >>> 0 };
}

/** `EVT INPUT <n> 0|1` body. */
export function parseInputEvent(body: string): { n: number; on: boolean } | null {
  const ws = words(body);
  if (ws.length < 2 || !DIGITS.test(ws[0]) || (ws[1] !== '0' && ws[1] !== '1')) return null;
  return { n: Number(ws[0]), on: ws[1] === '1' };
}

/** `EVT ERROR <code> <text>` body. */
export function parseErrorEvent(body: string): { code: number; text: string } | null {
  const ws = words(body);
  if (ws.length < 1 || !DIGITS.test(ws[0])) return null;
  return { code: Number(ws[0]), text: ws.slice(1).join(' ') };
}

/** `EVT PROGRAM <name> <state>` body. */
export function parseProgramEvent(body: string): { name: string; state: string } | null {
  const ws = words(body);
  if (ws.length < 2) return null;
  return { name: ws[0], state: ws[1].toUpperCase() };
}

/** `ACK programs=a,b` of `PROGRAMS`. */
export function parsePrograms(fields: Record<string, string>): string[] {
  const p = fields.programs ?? '';
  return p === '' ? [] : p.split(',').filter((s) => s.length > 0);
}

/** Verbs whose accepted request later ends with `INF` or `ABS`. */
const FINAL_VERBS = new Set(['HOME', 'MOVJ', 'MOVP', 'MOVL', 'JOG', 'WAIT', 'RUN', 'GET', 'PUT', 'SWAP', 'MAP', 'RETRACT', 'SENSE']);

/** The verb of a request line (upper case), skipping a leading id. */
export function verbOf(request: string): string {
  const ws = words(request);
  const i = ws.length > 0 && DIGITS.test(ws[0]) ? 1 : 0;
  return (ws[i] ?? '').toUpperCase();
}

/** Does this request complete later with `INF`/`ABS` once accepted? */
export function completesLater(request: string): boolean {
  return FINAL_VERBS.has(verbOf(request));
}

/** Request ids: 1 … 99,999,999 (8 digits), then round again. */
export class IdAllocator {
  private last: number;
  constructor(start = 0) {
    this.last = start;
  }
  next(): number {
    this.last = this.last >= 99_999_999 ? 1 : this.last + 1;
    return this.last;
  }
}

/** `<id> <request>`; the request must not carry an id of its own. */
export function formatRequest(id: number, request: string): string {
  return `${id} ${request.trim()}`;
}

/** Names of programs and trace files: 1-32 letters, digits, `_` or `-`. */
const NAME = /^[A-Za-z0-9_-]{1,32}$/;

/** Program names: 1-32 letters, digits, `_` or `-`. */
export function isProgramName(name: string): boolean {
  return NAME.test(name);
}

/** The request that saves the controller's trace: `TRACE SAVE`, or `TRACE SAVE <name>`. */
export function traceSaveRequest(name: string): string {
  const n = name.trim();
  if (n === '') return 'TRACE SAVE';
  if (!NAME.test(n)) throw new Error(`trace name "${n}" must be 1-32 letters, digits, _ or -`);
  return `TRACE SAVE ${n}`;
}

/** What `TRACE SAVE` wrote, from its `ACK`. */
export interface TraceSaved {
  /** Absolute path of the trace file on the controller's computer. */
  file: string;
  /** Samples and messages in the file, and the time its samples span [s] (null: not given). */
  samples: number | null;
  messages: number | null;
  seconds: number | null;
}

/** A trace saved, or why not (the NAK's code and text, or what was wrong with the ACK). */
export type TraceSaveOutcome = { ok: true; saved: TraceSaved } | { ok: false; text: string };

/**
 * The reply to `TRACE SAVE`: `ACK <id> file=<absolute path> samples=<n> messages=<m>
 * seconds=<s>` or `NAK <id> <code> <text>`. The path runs to the next ` key=` or the end, so a
 * path with blanks is kept whole.
 */
export function traceSaveOutcome(first: FirstReply): TraceSaveOutcome {
  if (first.kind === 'NAK') return { ok: false, text: `${first.code} ${first.text}`.trim() };
  const rest = stripChecksum(first.line);
  const m = /(?:^|[ \t])file=(.*?)(?=[ \t]+[A-Za-z_][A-Za-z0-9_]*=|[ \t]*$)/.exec(rest);
  const file = m?.[1] ?? '';
  if (file === '') return { ok: false, text: `the controller's reply names no file: ${first.line}` };
  const count = (v: string | undefined): number | null => {
    if (v === undefined || v === '') return null;
    const n = Number(v);
    return Number.isFinite(n) ? n : null;
  };
  return {
    ok: true,
    saved: {
      file,
      samples: count(first.fields.samples),
      messages: count(first.fields.messages),
      seconds: count(first.fields.seconds),
    },
  };
}

/**
 * The frame that uploads a program: `<id> UPLOAD <name>`, its lines, then `.`. Throws when a
 * line of the text is exactly `.` (it would end the upload early and the rest would be run as
 * requests).
 */
export function formatUpload(id: number, name: string, text: string): string {
  const lines = text.replace(/\r\n?/g, '\n').split('\n');
  if (lines.length > 0 && lines[lines.length - 1] === '') lines.pop();
  lines.forEach((l, i) => {
    if (l.trim() === '.') {
      throw new Error(`line ${i + 1} is a lone "." which would end the upload; remove it`);
    }
  });
  return [`${id} UPLOAD ${name}`, ...lines, '.'].join('\n');
}

/** A number as the protocol writes it: at most 3 decimals, no trailing zeros. */
export function fmtNum(v: number, decimals = 3): string {
  if (!Number.isFinite(v)) return '0';
  const s = v.toFixed(decimals);
  const t = s.includes('.') ? s.replace(/0+$/, '').replace(/\.$/, '') : s;
  return t === '-0' ? '0' : t;
}

/** Default texts of the alarm and fatal codes (docs/protocol.md, "Codes"), for `err=<code>`. */
const ALARM_TEXT: Record<number, string> = {
  200: 'stopped by STOP',
  201: 'emergency stop',
  202: 'emergency-stop input opened',
  203: 'following error',
  204: 'soft limit reached',
  205: 'servo alarm',
  206: 'motion board watchdog expired',
  207: 'real-time task overran its period',
  208: 'controlling client lost',
  209: 'motion fault',
  210: 'program error',
  211: 'WAIT timed out',
  212: 'wafer not sensed',
  213: 'wafer lost',
  214: 'station interlock opened',
  215: 'the program raised an alarm',
  216: 'a transfer was interrupted by a power loss; RECOVERY says what is uncertain',
  300: 'motion board lost',
  301: 'internal error',
};

/** `<code> <default text>` of an error code (`err=` of STATUS); '' for 0. */
export function errorText(code: number): string {
  if (!code) return '';
  return `${code} ${ALARM_TEXT[code] ?? 'error'}`;
}
