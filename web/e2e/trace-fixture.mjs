// Trace files built field by field as docs/trace.md lays them out (format version 2), for the
// GUI's tests: the unit tests of src/trace/trace.ts and the browser end-to-end test, which writes
// one into a temporary file and opens it in the trace viewer. Plain JavaScript (the e2e test
// runs on Node without a TypeScript step); its types are in trace-fixture.d.mts.
//
// Written apart from the reader on purpose: its own CRC-32 (bit by bit, no table) and BigInt
// integers, so a test compares the reader with the document, not with itself.

const enc = new TextEncoder();

/** The state names the controller writes (the numbers of `wrc_protocol::State`). */
export const STATE_NAMES = ['IDLE', 'MOVING', 'STOPPING', 'ERROR', 'ESTOP', 'HELD'];

/** The format version a file is written with unless told. */
export const FORMAT_VERSION = 2;

/** The direction codes of a message record. */
export const DIRECTION_CODES = { request: 0, reply: 1, opened: 2, closed: 3 };

/** CRC-32 (IEEE, reflected, as zlib) of `bytes`, one bit at a time. */
export function crc32Bitwise(bytes) {
  let c = 0xffffffff;
  for (const b of bytes) {
    c ^= b;
    for (let k = 0; k < 8; k++) c = c & 1 ? (c >>> 1) ^ 0xedb88320 : c >>> 1;
  }
  return (c ^ 0xffffffff) >>> 0;
}

/** Little-endian bytes, appended field by field. */
class Bytes {
  constructor() {
    this.parts = [];
  }
  raw(bytes) {
    this.parts.push(Uint8Array.from(bytes));
    return this;
  }
  int(bytes, set, value) {
    const b = new Uint8Array(bytes);
    set(new DataView(b.buffer), value);
    return this.raw(b);
  }
  u8(v) {
    return this.int(1, (d, x) => d.setUint8(0, x), v);
  }
  u16(v) {
    return this.int(2, (d, x) => d.setUint16(0, x, true), v);
  }
  u32(v) {
    return this.int(4, (d, x) => d.setUint32(0, x >>> 0, true), v);
  }
  u64(v) {
    return this.int(8, (d, x) => d.setBigUint64(0, BigInt(x), true), v);
  }
  i64(v) {
    return this.int(8, (d, x) => d.setBigInt64(0, BigInt(x), true), v);
  }
  str(s) {
    const b = enc.encode(s);
    return this.u32(b.length).raw(b);
  }
  optStr(s) {
    return s === null || s === undefined ? this.u8(0) : this.u8(1).str(s);
  }
  bytes() {
    const n = this.parts.reduce((k, p) => k + p.length, 0);
    const out = new Uint8Array(n);
    let at = 0;
    for (const p of this.parts) {
      out.set(p, at);
      at += p.length;
    }
    return out;
  }
}

/** A section: tag, u64 body length, body, CRC-32 of tag, length and body. */
export function section(tag, body, { length = body.length, crc } = {}) {
  const head = new Bytes().raw(enc.encode(tag)).u64(length).raw(body).bytes();
  return new Bytes().raw(head).u32(crc ?? crc32Bitwise(head)).bytes();
}

/** The meta body; every field has a default. */
export function metaBody(meta = {}) {
  const m = {
    wrcVersion: '0.1.0',
    reason: 'TRACE SAVE',
    clock: 'monotonic',
    periodNs: 10_000_000,
    axisNames: ['j1', 'j2', 'j3', 'z'],
    stateNames: STATE_NAMES,
    configToml: '',
    stationsToml: null,
    wafersToml: null,
    worldToml: null,
    programs: [],
    startPulses: [],
    fromStart: false,
    savedAtNs: 0,
    ...meta,
  };
  const b = new Bytes().str(m.wrcVersion).str(m.reason).u8(m.clock === 'virtual' ? 1 : 0).u64(m.periodNs);
  b.u32(m.axisNames.length);
  for (const n of m.axisNames) b.str(n);
  b.u32(m.stateNames.length);
  for (const n of m.stateNames) b.str(n);
  b.str(m.configToml).optStr(m.stationsToml).optStr(m.wafersToml).optStr(m.worldToml);
  b.u32(m.programs.length);
  for (const p of m.programs) b.str(p.name).str(p.text);
  b.u32(m.startPulses.length);
  for (const p of m.startPulses) b.i64(p);
  return b.u8(m.fromStart ? 1 : 0).u64(m.savedAtNs).bytes();
}

/** The samples body: a u64 count, then 29 + 16 × axes bytes per sample. */
export function samplesBody(samples, axes, count = samples.length) {
  const b = new Bytes().u64(count);
  for (const s of samples) {
    b.u64(s.tNs);
    for (let a = 0; a < axes; a++) b.i64(s.commanded?.[a] ?? 0);
    for (let a = 0; a < axes; a++) b.i64(s.actual?.[a] ?? 0);
    b.u32(s.inputs ?? 0).u32(s.outputs ?? 0).u8(s.state ?? 0).u16(s.errorCode ?? 0).u16(s.fifoLevel ?? 0);
    b.u32(s.latencyNs ?? 0).u32(s.execNs ?? 0);
  }
  return b.bytes();
}

/**
 * The messages body: a u64 count, then 15 bytes and the line per message. A direction is a
 * name (`request`, `reply`, `opened`, `closed`) or a code written as it is (to test a bad one);
 * an opened or closed message's line defaults to empty.
 */
export function messagesBody(messages, count = messages.length) {
  const b = new Bytes().u64(count);
  for (const m of messages) {
    const line = enc.encode(m.line ?? '');
    const code = typeof m.direction === 'number' ? m.direction : DIRECTION_CODES[m.direction];
    if (code === undefined) throw new Error(`no direction code for ${JSON.stringify(m.direction)}`);
    b.u64(m.tNs).u8(code).u8(m.source ?? 0).u16(m.client ?? 0);
    b.u8(m.truncated ? 1 : 0).u16(line.length).raw(line);
  }
  return b.bytes();
}

/** The header (magic, version) and the given sections, in the order given. */
export function traceBytes(sections, { version = FORMAT_VERSION, magic = 'WRCTRACE' } = {}) {
  const b = new Bytes().raw(enc.encode(magic)).u32(version);
  for (const s of sections) b.raw(s);
  return b.bytes();
}

/** A whole, valid trace file. */
export function encodeTrace({ meta = {}, samples = [], messages = [], version = FORMAT_VERSION } = {}) {
  const axes = (meta.axisNames ?? ['j1', 'j2', 'j3', 'z']).length;
  return traceBytes(
    [
      section('META', metaBody(meta)),
      section('SMPL', samplesBody(samples, axes)),
      section('MESG', messagesBody(messages)),
      section('END\0', new Uint8Array(0)),
    ],
    { version },
  );
}
