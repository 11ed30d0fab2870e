// Trace files (docs/trace.md, format version 2) read in the browser, and the lookups the
// trace viewer scrubs with. `readTrace` mirrors the controller's reader (crates/wrc-trace,
// format.rs): it returns a trace or one of the same five errors as a sentence naming the file,
// never throws, and never trusts a length (a section is read only as far as the data goes,
// every count is checked against the bytes left before anything is reserved).
//
// No DOM: every function here is unit-tested on bytes built field by field.

import { getI64, getU64 } from '../le64';

/** The first 8 bytes of every trace file. */
export const TRACE_MAGIC = 'WRCTRACE';
/** The trace format this GUI reads; every other version is refused. */
export const TRACE_FORMAT_VERSION = 2;
/** Most axes a trace has. */
export const TRACE_MAX_AXES = 16;
/** Longest line a message keeps [byte]. */
export const TRACE_MAX_MESSAGE = 256;
/** Longest section body a reader accepts [byte]. */
export const TRACE_MAX_SECTION_BYTES = 2 ** 32;

/** Bytes of one sample in a file with `axes` axes. */
export function sampleFileBytes(axes: number): number {
  return 29 + 16 * axes;
}

/** Bytes of a message record before its line: t_ns, direction, source, client, flags, length. */
const MESSAGE_HEAD_BYTES = 15;

// ---------------------------------------------------------------------------------------------
// What a trace holds

/** Where a trace's times come from: the controller ran in real time, or under virtual time. */
export type TraceClock = 'monotonic' | 'virtual';

/** What a trace says about itself (the meta section). */
export interface TraceMeta {
  /** Version of the wrc that wrote the file. */
  wrcVersion: string;
  /** Why it was saved: `TRACE SAVE`, `alarm 206 motion board watchdog expired`, …. */
  reason: string;
  clock: TraceClock;
  /** Sample period [ns]. */
  periodNs: number;
  /** One name per axis, in axis order; their number is the trace's axis count (0-16). */
  axisNames: string[];
  /** State code → name (`TraceSample.state` indexes it). */
  stateNames: string[];
  /** The configuration text (TOML) the controller ran. */
  configToml: string;
  stationsToml: string | null;
  wafersToml: string | null;
  worldToml: string | null;
  /** Stored robot programs at session start. */
  programs: { name: string; text: string }[];
  /** Commanded position per axis at session start [pulse]. */
  startPulses: number[];
  /** The messages cover the session from its start. */
  fromStart: boolean;
  /** Controller clock when the trace was saved [ns]. */
  savedAtNs: number;
}

/** One period as the Pulse Generator saw it. */
export interface TraceSample {
  /** Controller clock [ns since the controller started]. */
  tNs: number;
  /** Commanded and encoder position per axis [pulse]. */
  commanded: number[];
  actual: number[];
  /** Digital inputs and outputs of board 0 (bit n = input or output n). */
  inputs: number;
  outputs: number;
  /** Robot state code (see `TraceMeta.stateNames`). */
  state: number;
  /** Last error code, 0 none. */
  errorCode: number;
  /** The board's command FIFO level [periods]. */
  fifoLevel: number;
  /** The Pulse Generator's wake-up latency and its previous execution time [ns]. */
  latencyNs: number;
  execNs: number;
}

/**
 * The samples of a trace, column by column (a trace of an hour holds hundreds of thousands):
 * sample `i`'s position of axis `a` is at `i * axes + a` of `commanded` and `actual`.
 */
export class TraceSamples {
  constructor(
    readonly axes: number,
    readonly tNs: Float64Array,
    readonly commanded: Float64Array,
    readonly actual: Float64Array,
    readonly inputs: Uint32Array,
    readonly outputs: Uint32Array,
    readonly state: Uint8Array,
    readonly errorCode: Uint16Array,
    readonly fifoLevel: Uint16Array,
    readonly latencyNs: Uint32Array,
    readonly execNs: Uint32Array,
  ) {}

  static empty(axes: number, count: number): TraceSamples {
    return new TraceSamples(
      axes,
      new Float64Array(count),
      new Float64Array(count * axes),
      new Float64Array(count * axes),
      new Uint32Array(count),
      new Uint32Array(count),
      new Uint8Array(count),
      new Uint16Array(count),
      new Uint16Array(count),
      new Uint32Array(count),
      new Uint32Array(count),
    );
  }

  get count(): number {
    return this.tNs.length;
  }

  /** Sample `i` (0 ≤ i < count) as one object. */
  at(i: number): TraceSample {
    const from = i * this.axes;
    return {
      tNs: this.tNs[i] ?? 0,
      commanded: Array.from(this.commanded.subarray(from, from + this.axes)),
      actual: Array.from(this.actual.subarray(from, from + this.axes)),
      inputs: this.inputs[i] ?? 0,
      outputs: this.outputs[i] ?? 0,
      state: this.state[i] ?? 0,
      errorCode: this.errorCode[i] ?? 0,
      fifoLevel: this.fifoLevel[i] ?? 0,
      latencyNs: this.latencyNs[i] ?? 0,
      execNs: this.execNs[i] ?? 0,
    };
  }

  /** Encoder position of axis `axis` in sample `i` [pulse]. */
  actualAt(i: number, axis: number): number {
    return this.actual[i * this.axes + axis] ?? 0;
  }

  /**
   * The last sample at or before `tNs` (0 before the first; the samples are in time order, as
   * the Pulse Generator pushed them); -1 when there are none.
   */
  indexAt(tNs: number): number {
    const t = this.tNs;
    if (t.length === 0) return -1;
    let lo = 0;
    let hi = t.length - 1;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if ((t[mid] as number) <= tNs) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  }
}

/**
 * What a message records, by its direction code: a line received (0, a request), a line sent
 * (1, a reply or an event), a client connecting (2, opened) or its connection closing, by the
 * client or by the controller (3, closed). An opened or closed message has an empty line; its
 * source and client say which connection.
 */
export type TraceDirection = 'request' | 'reply' | 'opened' | 'closed';

/** The directions by their code in a file. */
const DIRECTIONS: readonly TraceDirection[] = ['request', 'reply', 'opened', 'closed'];

/** One protocol line received or sent. */
export interface TraceMessage {
  /** Controller clock when the line was received or sent, or the connection opened or closed [ns]. */
  tNs: number;
  direction: TraceDirection;
  /** 0 host on TCP, 1 GUI, 2 pendant, 3 program, 255 broadcast or event (see `sourceName`). */
  source: number;
  /** The client's connection slot. */
  client: number;
  /** The line was longer than 256 bytes and only its start is kept. */
  truncated: boolean;
  /** The line without its LF (bytes that are not UTF-8 shown as U+FFFD); empty when opened or closed. */
  line: string;
}

/** A trace file's content. */
export interface Trace {
  meta: TraceMeta;
  samples: TraceSamples;
  /** In file order. */
  messages: TraceMessage[];
}

/** The name of a message source code. */
export function sourceName(source: number): string {
  switch (source) {
    case 0:
      return 'host';
    case 1:
      return 'gui';
    case 2:
      return 'pendant';
    case 3:
      return 'program';
    case 255:
      return 'event';
    default:
      return `source ${source}`;
  }
}

/** How the trace viewer lists a message: an arrow, its text and a tooltip. */
export interface MessageText {
  /** `→` received, `←` sent, `⇢` a client connected, `⇠` a connection closed. */
  arrow: string;
  /** The line (`…` after one cut at 256 bytes), or what happened to the connection. */
  text: string;
  /** Who the line came from or went to, or which connection opened or closed. */
  title: string;
}

/** What the trace viewer shows for `msg` (no DOM, so that it is unit-tested). */
export function describeMessage(msg: TraceMessage): MessageText {
  const who = `${sourceName(msg.source)} client ${msg.client}`;
  const cut = msg.truncated ? '; longer than 256 bytes, cut' : '';
  const line = msg.line + (msg.truncated ? '…' : '');
  switch (msg.direction) {
    case 'request':
      return { arrow: '→', text: line, title: `received from ${who}${cut}` };
    case 'reply':
      return { arrow: '←', text: line, title: `sent to ${who}${cut}` };
    case 'opened':
      return { arrow: '⇢', text: `client ${msg.client} connected`, title: `${who} connected` };
    case 'closed':
      return {
        arrow: '⇠',
        text: `client ${msg.client} closed`,
        title: `${who}: its connection closed (by the client or by the controller)`,
      };
  }
}

// ---------------------------------------------------------------------------------------------
// Errors

/** The five ways a trace cannot be read, as `wrc_trace::TraceError` names them. */
export type TraceErrorKind = 'NotATrace' | 'Version' | 'Truncated' | 'Corrupt' | 'Invalid';

/** Why a trace cannot be read: its kind and one sentence naming the file. */
export interface TraceReadError {
  kind: TraceErrorKind;
  message: string;
}

export type TraceRead = { ok: true; trace: Trace } | { ok: false; error: TraceReadError };

/** Thrown inside the reader only; `readTrace` turns it into its result. */
class Refusal {
  constructor(readonly error: TraceReadError) {}
}

/** A section of the file: its tag and its names in messages. */
interface Section {
  tag: string;
  name: string;
  /** Where a reader that runs out of data is. */
  inside: string;
}

const META: Section = { tag: 'META', name: 'meta', inside: 'the meta section' };
const SAMPLES: Section = { tag: 'SMPL', name: 'samples', inside: 'the samples section' };
const MESSAGES: Section = { tag: 'MESG', name: 'messages', inside: 'the messages section' };
const END: Section = { tag: 'END\0', name: 'end', inside: 'the end section' };

// ---------------------------------------------------------------------------------------------
// CRC-32

let crcTable: Uint32Array | null = null;

/**
 * CRC-32 (IEEE 802.3, reflected, as zlib and `crc32fast`) of `bytes`, continuing from `crc`
 * (0 to start). Hand-written: twelve lines, and no npm package of ours has it.
 */
export function crc32(bytes: Uint8Array, crc = 0): number {
  if (crcTable === null) {
    crcTable = new Uint32Array(256);
    for (let n = 0; n < 256; n++) {
      let c = n;
      for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
      crcTable[n] = c >>> 0;
    }
  }
  let c = ~crc >>> 0;
  for (let i = 0; i < bytes.length; i++) c = (crcTable[(c ^ (bytes[i] as number)) & 0xff] as number) ^ (c >>> 8);
  return ~c >>> 0;
}

// ---------------------------------------------------------------------------------------------
// Reading

/**
 * Read a trace file's bytes; `file` names it in the error sentences. Never throws: a bad
 * magic, another version, a truncated or corrupt file and a content that breaks the format
 * each come back as `{ ok: false, error }`.
 */
export function readTrace(data: ArrayBuffer | Uint8Array, file = 'the file'): TraceRead {
  try {
    const bytes = data instanceof Uint8Array ? data : new Uint8Array(data);
    return { ok: true, trace: new Reader(bytes, file).read() };
  } catch (e) {
    if (e instanceof Refusal) return { ok: false, error: e.error };
    // Not expected (every length is checked); still a sentence, never an exception.
    return { ok: false, error: { kind: 'Invalid', message: `${file} is not a valid trace: ${String(e)}` } };
  }
}

function tagBytes(section: Section): Uint8Array {
  return new Uint8Array([...section.tag].map((c) => c.charCodeAt(0)));
}

function tagText(bytes: Uint8Array): string {
  let s = '';
  for (const b of bytes) s += b >= 0x20 && b < 0x7f ? String.fromCharCode(b) : `\\x${b.toString(16).padStart(2, '0')}`;
  return `"${s.replace(/\\x00/g, '\\0')}"`;
}

class Reader {
  private readonly view: DataView;
  private pos = 0;

  constructor(
    private readonly bytes: Uint8Array,
    private readonly file: string,
  ) {
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  }

  refuse(kind: TraceErrorKind, message: string): Refusal {
    return new Refusal({ kind, message: `${this.file} ${message}` });
  }

  invalid(reason: string): Refusal {
    return this.refuse('Invalid', `is not a valid trace: ${reason}`);
  }

  truncated(what: string): Refusal {
    return this.refuse('Truncated', `is truncated: it ends inside ${what}; the file is incomplete`);
  }

  corrupt(section: Section): Refusal {
    return this.refuse('Corrupt', `is corrupt: its ${section.name} section fails its CRC-32 check`);
  }

  read(): Trace {
    const b = this.bytes;
    const got = Math.min(b.length, TRACE_MAGIC.length);
    for (let i = 0; i < got; i++) {
      if (b[i] !== TRACE_MAGIC.charCodeAt(i)) {
        throw this.refuse('NotATrace', `is not a wrc trace: it does not start with "${TRACE_MAGIC}"`);
      }
    }
    if (b.length < 12) throw this.truncated('the header');
    const version = this.view.getUint32(8, true);
    if (version !== TRACE_FORMAT_VERSION) {
      const newer = version > TRACE_FORMAT_VERSION;
      throw this.refuse(
        'Version',
        `was written by ${newer ? 'a newer' : 'an older'} wrc (trace format ${version}); this GUI reads trace ` +
          `format ${TRACE_FORMAT_VERSION} only: ${newer ? 'open it with a newer wrc' : 'read it with the wrc that wrote it'}`,
      );
    }
    this.pos = 12;
    const meta = decodeMeta(new Body(this.section(META), META, this));
    const samples = decodeSamples(new Body(this.section(SAMPLES), SAMPLES, this), meta.axisNames.length);
    const messages = decodeMessages(new Body(this.section(MESSAGES), MESSAGES, this));
    const end = this.section(END);
    if (end.length !== 0) throw this.invalid(`its end section has ${end.length} bytes; it has none`);
    // Bytes after the end section are not read.
    return { meta, samples, messages };
  }

  /** One section at the current position: check its CRC, then its tag; its body. */
  private section(section: Section): Uint8Array {
    const start = this.pos;
    const left = (): number => this.bytes.length - this.pos;
    if (left() < 12) throw this.truncated(section.inside);
    const tag = this.bytes.subarray(start, start + 4);
    const want = tagBytes(section);
    const tagMatches = tag.every((c, i) => c === want[i]);
    const n = getU64(this.view, start + 4);
    if (n > TRACE_MAX_SECTION_BYTES) {
      // A damaged length is the likely cause when the tag is the expected one.
      throw tagMatches ? this.corrupt(section) : this.unexpectedTag(tag, section);
    }
    this.pos += 12;
    if (left() < n) throw this.truncated(section.inside);
    const body = this.bytes.subarray(this.pos, this.pos + n);
    this.pos += n;
    if (left() < 4) throw this.truncated(section.inside);
    const stored = this.view.getUint32(this.pos, true);
    this.pos += 4;
    if (stored !== crc32(this.bytes.subarray(start, start + 12 + n))) throw this.corrupt(section);
    if (!tagMatches) throw this.unexpectedTag(tag, section);
    return body;
  }

  private unexpectedTag(tag: Uint8Array, section: Section): Refusal {
    const want = tagText(tagBytes(section));
    return this.invalid(`the ${section.name} section (tag ${want}) was expected, found tag ${tagText(tag)}`);
  }
}

const utf8 = new TextDecoder('utf-8', { fatal: true, ignoreBOM: true });
const lenientUtf8 = new TextDecoder('utf-8', { fatal: false, ignoreBOM: true });

/** A section body being decoded; running out of it breaks the format. */
class Body {
  private readonly view: DataView;
  private pos = 0;

  constructor(
    private readonly bytes: Uint8Array,
    private readonly section: Section,
    private readonly reader: Reader,
  ) {
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  }

  get left(): number {
    return this.bytes.length - this.pos;
  }

  invalid(reason: string): Refusal {
    return this.reader.invalid(reason);
  }

  /** Move past `n` bytes of `field`; the offset they start at. */
  private take(n: number, field: string): number {
    if (n > this.left) {
      throw this.invalid(`its ${this.section.name} section ends inside ${field} (${n} bytes wanted, ${this.left} left)`);
    }
    const at = this.pos;
    this.pos += n;
    return at;
  }

  u8(field: string): number {
    return this.view.getUint8(this.take(1, field));
  }
  u16(field: string): number {
    return this.view.getUint16(this.take(2, field), true);
  }
  u32(field: string): number {
    return this.view.getUint32(this.take(4, field), true);
  }
  u64(field: string): number {
    return getU64(this.view, this.take(8, field));
  }
  i64(field: string): number {
    return getI64(this.view, this.take(8, field));
  }

  bool(field: string): boolean {
    const n = this.u8(field);
    if (n > 1) throw this.invalid(`${field} is ${n}; it is 0 or 1`);
    return n === 1;
  }

  bytesOf(n: number, field: string): Uint8Array {
    const at = this.take(n, field);
    return this.bytes.subarray(at, at + n);
  }

  string(field: string): string {
    const raw = this.bytesOf(this.u32(field), field);
    try {
      return utf8.decode(raw);
    } catch {
      throw this.invalid(`${field} is not UTF-8`);
    }
  }

  optString(field: string): string | null {
    return this.bool(field) ? this.string(field) : null;
  }

  /** A count of entries of at least `minBytes` each, checked against the bytes left. */
  count(field: string, n: number, minBytes: number): number {
    const room = Math.floor(this.left / Math.max(1, minBytes));
    if (n > room) {
      throw this.invalid(`its ${this.section.name} section says ${n} ${field}, but holds room for at most ${room}`);
    }
    return n;
  }

  finish(): void {
    if (this.left !== 0) throw this.invalid(`its ${this.section.name} section has ${this.left} bytes after its last field`);
  }
}

function decodeMeta(b: Body): TraceMeta {
  const wrcVersion = b.string('wrc_version');
  const reason = b.string('reason');
  const clockCode = b.u8('clock');
  if (clockCode > 1) throw b.invalid(`its clock code is ${clockCode}; it is 0 or 1`);
  const periodNs = b.u64('period_ns');
  const axes = b.u32('axis_names');
  if (axes > TRACE_MAX_AXES) throw b.invalid(`it has ${axes} axes; a trace has at most ${TRACE_MAX_AXES}`);
  const axisNames: string[] = [];
  for (let i = 0; i < axes; i++) axisNames.push(b.string('an axis name'));
  const states = b.count('state names', b.u32('state_names'), 4);
  const stateNames: string[] = [];
  for (let i = 0; i < states; i++) stateNames.push(b.string('a state name'));
  const configToml = b.string('config_toml');
  const stationsToml = b.optString('stations_toml');
  const wafersToml = b.optString('wafers_toml');
  const worldToml = b.optString('world_toml');
  const nPrograms = b.count('programs', b.u32('programs'), 8);
  const programs: { name: string; text: string }[] = [];
  for (let i = 0; i < nPrograms; i++) programs.push({ name: b.string('a program name'), text: b.string('a program text') });
  const nStart = b.count('start pulses', b.u32('start_pulses'), 8);
  const startPulses: number[] = [];
  for (let i = 0; i < nStart; i++) startPulses.push(b.i64('a start pulse'));
  const fromStart = b.bool('from_start');
  const savedAtNs = b.u64('saved_at_ns');
  b.finish();
  return {
    wrcVersion,
    reason,
    clock: clockCode === 0 ? 'monotonic' : 'virtual',
    periodNs,
    axisNames,
    stateNames,
    configToml,
    stationsToml,
    wafersToml,
    worldToml,
    programs,
    startPulses,
    fromStart,
    savedAtNs,
  };
}

function decodeSamples(b: Body, axes: number): TraceSamples {
  const size = sampleFileBytes(axes);
  const n = b.u64('the sample count');
  if (b.left !== n * size) {
    throw b.invalid(`its samples section says ${n} samples of ${size} bytes but holds ${b.left} bytes`);
  }
  const s = TraceSamples.empty(axes, b.count('samples', n, size));
  for (let i = 0; i < s.count; i++) {
    s.tNs[i] = b.u64('a sample');
    for (let a = 0; a < axes; a++) s.commanded[i * axes + a] = b.i64('a sample');
    for (let a = 0; a < axes; a++) s.actual[i * axes + a] = b.i64('a sample');
    s.inputs[i] = b.u32('a sample');
    s.outputs[i] = b.u32('a sample');
    s.state[i] = b.u8('a sample');
    s.errorCode[i] = b.u16('a sample');
    s.fifoLevel[i] = b.u16('a sample');
    s.latencyNs[i] = b.u32('a sample');
    s.execNs[i] = b.u32('a sample');
  }
  b.finish();
  return s;
}

function decodeMessages(b: Body): TraceMessage[] {
  const n = b.count('messages', b.u64('the message count'), MESSAGE_HEAD_BYTES);
  const messages: TraceMessage[] = [];
  for (let i = 0; i < n; i++) {
    const tNs = b.u64('a message');
    const d = b.u8('a message');
    const direction = DIRECTIONS[d];
    if (direction === undefined) {
      throw b.invalid(`a message has direction code ${d}; it is 0 to ${DIRECTIONS.length - 1}`);
    }
    const source = b.u8('a message');
    const client = b.u16('a message');
    const truncated = b.bool("a message's truncated flag");
    const len = b.u16('a message');
    if (len > TRACE_MAX_MESSAGE) {
      throw b.invalid(`a message is ${len} bytes long; a message keeps at most ${TRACE_MAX_MESSAGE}`);
    }
    // A line cut at 256 bytes may end inside a character: shown, not refused.
    const line = lenientUtf8.decode(b.bytesOf(len, 'a message'));
    messages.push({ tNs, direction, source, client, truncated, line });
  }
  b.finish();
  return messages;
}

// ---------------------------------------------------------------------------------------------
// Scrubbing

/** The messages in time order (a stable sort: lines of one time keep their file order). */
export function byTime(messages: readonly TraceMessage[]): TraceMessage[] {
  return [...messages].sort((a, b) => a.tNs - b.tNs);
}

/** The first index of `sorted` whose time is at or after `tNs` (`after`: strictly after). */
function search(sorted: readonly TraceMessage[], tNs: number, after: boolean): number {
  let lo = 0;
  let hi = sorted.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    const t = (sorted[mid] as TraceMessage).tNs;
    if (t < tNs || (after && t === tNs)) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

/**
 * The messages within `windowNs` of `tNs` in `sorted` (from `byTime`): indices `from` to
 * `to` (exclusive), and `current`, the last of them at or before `tNs` (null when none is).
 */
export function messagesNear(
  sorted: readonly TraceMessage[],
  tNs: number,
  windowNs: number,
): { from: number; to: number; current: number | null } {
  const from = search(sorted, tNs - windowNs, false);
  const to = search(sorted, tNs + windowNs, true);
  const upToNow = search(sorted, tNs, true);
  return { from, to, current: upToNow > from ? upToNow - 1 : null };
}

/** A 32-bit word as `0x` and eight hex digits (the I/O words of a sample). */
export function hex32(word: number): string {
  return `0x${(word >>> 0).toString(16).padStart(8, '0')}`;
}
