import { describe, expect, it } from 'vitest';
import {
  STATE_NAMES,
  crc32Bitwise,
  encodeTrace,
  messagesBody,
  metaBody,
  samplesBody,
  section,
  traceBytes,
  type FixtureMessage,
  type FixtureSample,
} from '../../e2e/trace-fixture.mjs';
import {
  TRACE_FORMAT_VERSION,
  byTime,
  crc32,
  describeMessage,
  hex32,
  messagesNear,
  readTrace,
  sourceName,
  type Trace,
  type TraceMessage,
  type TraceRead,
} from './trace';

const enc = new TextEncoder();

/** 3 axes, 5 samples 10 ms apart: J1 moves, the state goes IDLE → MOVING, input 2 rises. */
const SAMPLES: FixtureSample[] = [0, 1, 2, 3, 4].map((k) => ({
  tNs: 1_000_000_000 + k * 10_000_000,
  commanded: [k * 1000, -75_000, 2 ** 40],
  actual: [k * 1000 - 40, -75_001, -(2 ** 40)],
  inputs: k > 2 ? 0xdeadbeef : 0,
  outputs: 1,
  state: k >= 2 ? 1 : 0,
  errorCode: k === 4 ? 206 : 0,
  fifoLevel: 2 + k,
  latencyNs: 15_000 + k,
  execNs: 40_000 + k,
}));

const MESSAGES: FixtureMessage[] = [
  { tNs: 1_015_000_000, direction: 'request', source: 0, client: 3, line: '1 MOVJ 60 0 0' },
  { tNs: 1_016_000_000, direction: 'reply', source: 0, client: 3, line: 'ACK 1' },
  { tNs: 1_020_000_000, direction: 'reply', source: 255, client: 0, line: 'EVT STATE MOVING ✓' },
  { tNs: 1_030_000_000, direction: 'request', source: 1, client: 7, truncated: true, line: 'x'.repeat(256) },
];

const META = {
  wrcVersion: '0.1.0',
  reason: 'alarm 206 motion board watchdog expired',
  clock: 'virtual' as const,
  periodNs: 10_000_000,
  axisNames: ['Theta', 'Reach', 'Zeta'],
  stateNames: STATE_NAMES,
  configToml: '[robot]\nname = "r"\n',
  stationsToml: '[[station]]\nname = "LP1"\n',
  wafersToml: null,
  worldToml: '',
  programs: [{ name: 'demo', text: 'SPEED 50\n' }],
  startPulses: [0, -75_000, 12],
  fromStart: true,
  savedAtNs: 2_000_000_000,
};

function valid(): Uint8Array {
  return encodeTrace({ meta: META, samples: SAMPLES, messages: MESSAGES });
}

function trace(r: TraceRead): Trace {
  if (!r.ok) throw new Error(`expected a trace: ${r.error.message}`);
  return r.trace;
}

function refusal(r: TraceRead): { kind: string; message: string } {
  if (r.ok) throw new Error('expected the trace to be refused');
  return r.error;
}

/** The file with its sections as given (each sealed with its CRC). */
function withSections(...sections: [string, Uint8Array][]): Uint8Array {
  return traceBytes(sections.map(([tag, body]) => section(tag, body)));
}

const meta = (): [string, Uint8Array] => ['META', metaBody(META)];
const samples = (): [string, Uint8Array] => ['SMPL', samplesBody(SAMPLES, 3)];
const messages = (): [string, Uint8Array] => ['MESG', messagesBody(MESSAGES)];
const end = (): [string, Uint8Array] => ['END\0', new Uint8Array(0)];

/** Offsets of each section's first byte (its tag) in `valid()`. */
function sectionStarts(bytes: Uint8Array): number[] {
  const v = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const starts: number[] = [];
  let at = 12;
  for (let i = 0; i < 4; i++) {
    starts.push(at);
    at += 12 + Number(v.getBigUint64(at + 4, true)) + 4;
  }
  return starts;
}

describe('crc32', () => {
  it('gives the check value of CRC-32/ISO-HDLC and agrees with a bitwise CRC', () => {
    expect(crc32(enc.encode('123456789'))).toBe(0xcbf43926);
    expect(crc32(new Uint8Array(0))).toBe(0);
    const bytes = Uint8Array.from({ length: 1000 }, (_, i) => (i * 97 + 13) & 0xff);
    expect(crc32(bytes)).toBe(crc32Bitwise(bytes));
    // Continued over two parts as over the whole.
    expect(crc32(bytes.subarray(400), crc32(bytes.subarray(0, 400)))).toBe(crc32(bytes));
  });
});

describe('readTrace', () => {
  it('reads every field of a valid trace', () => {
    const t = trace(readTrace(valid(), 'session.wrctrace'));
    expect(t.meta).toEqual({
      ...META,
      wafersToml: null,
    });
    expect(t.samples.count).toBe(5);
    expect(t.samples.axes).toBe(3);
    expect(t.samples.at(3)).toEqual({
      tNs: 1_030_000_000,
      commanded: [3000, -75_000, 2 ** 40],
      actual: [2960, -75_001, -(2 ** 40)],
      inputs: 0xdeadbeef,
      outputs: 1,
      state: 1,
      errorCode: 0,
      fifoLevel: 5,
      latencyNs: 15_003,
      execNs: 40_003,
    });
    expect(t.samples.at(4).errorCode).toBe(206);
    expect(t.samples.actualAt(1, 0)).toBe(960);
    expect(t.messages).toEqual(MESSAGES.map((m) => ({ source: 0, client: 0, truncated: false, ...m })));
  });

  it('reads a trace without axes, samples or messages', () => {
    const t = trace(readTrace(encodeTrace({ meta: { axisNames: [], stateNames: [] } })));
    expect(t.meta.axisNames).toEqual([]);
    expect(t.samples.count).toBe(0);
    expect(t.samples.indexAt(5)).toBe(-1);
    expect(t.messages).toEqual([]);
  });

  it('reads a Uint8Array that is a window into a larger buffer, and ignores bytes after the end', () => {
    const file = valid();
    const big = new Uint8Array(file.length + 20);
    big.set(file, 7);
    big.fill(0xee, 7 + file.length);
    const t = trace(readTrace(big.subarray(7)));
    expect(t.samples.count).toBe(5);
  });

  it('refuses a file that does not start with WRCTRACE', () => {
    for (const bytes of [enc.encode('PK\x03\x04 a zip file'), enc.encode('WRCTRACX\x01\x00\x00\x00'), enc.encode('x')]) {
      const e = refusal(readTrace(bytes, 'a.wrctrace'));
      expect(e.kind).toBe('NotATrace');
      expect(e.message).toBe('a.wrctrace is not a wrc trace: it does not start with "WRCTRACE"');
    }
  });

  it('reads format version 2, as the fixture writes it', () => {
    expect(TRACE_FORMAT_VERSION).toBe(2);
    expect(new DataView(valid().buffer).getUint32(8, true)).toBe(2);
  });

  it('refuses every other format version, naming both', () => {
    const newer = refusal(readTrace(encodeTrace({ version: 3 }), 'a.wrctrace'));
    expect(newer.kind).toBe('Version');
    expect(newer.message).toBe(
      'a.wrctrace was written by a newer wrc (trace format 3); this GUI reads trace format 2 only: open it with a newer wrc',
    );
    const older = refusal(readTrace(encodeTrace({ version: 1 }), 'a.wrctrace'));
    expect(older.kind).toBe('Version');
    expect(older.message).toBe(
      'a.wrctrace was written by an older wrc (trace format 1); this GUI reads trace format 2 only: read it with the wrc that wrote it',
    );
    const zero = refusal(readTrace(encodeTrace({ version: 0 })));
    expect(zero.kind).toBe('Version');
    expect(zero.message).toContain('an older wrc (trace format 0)');
  });

  it('reads the messages of a client connecting and of its connection closing, with empty lines', () => {
    const session: FixtureMessage[] = [
      { tNs: 1_000_000_000, direction: 'opened', source: 0, client: 3 },
      { tNs: 1_015_000_000, direction: 'request', source: 0, client: 3, line: '1 MOVJ 60 0 0' },
      { tNs: 1_016_000_000, direction: 'reply', source: 0, client: 3, line: 'ACK 1' },
      { tNs: 1_017_000_000, direction: 'opened', source: 1, client: 7 },
      { tNs: 1_020_000_000, direction: 'closed', source: 0, client: 3 },
      { tNs: 1_030_000_000, direction: 'closed', source: 1, client: 7, line: '' },
    ];
    const t = trace(readTrace(encodeTrace({ meta: META, samples: SAMPLES, messages: session })));
    expect(t.messages.map((m) => [m.direction, m.source, m.client, m.line])).toEqual([
      ['opened', 0, 3, ''],
      ['request', 0, 3, '1 MOVJ 60 0 0'],
      ['reply', 0, 3, 'ACK 1'],
      ['opened', 1, 7, ''],
      ['closed', 0, 3, ''],
      ['closed', 1, 7, ''],
    ]);
    expect(t.messages.every((m) => !m.truncated)).toBe(true);
    // The codes as the document gives them: 2 opened, 3 closed.
    const body = messagesBody(session.slice(0, 1));
    expect(body[8 + 8]).toBe(2);
    expect(messagesBody([{ tNs: 0, direction: 'closed' }])[8 + 8]).toBe(3);
  });

  it('says where a file cut anywhere ends', () => {
    const file = valid();
    const starts = sectionStarts(file);
    const inside = (cut: number): string => {
      if (cut < 12) return 'the header';
      const names = ['meta', 'samples', 'messages', 'end'];
      let k = 0;
      while (k + 1 < starts.length && cut >= (starts[k + 1] as number)) k++;
      return `the ${names[k]} section`;
    };
    for (let cut = 0; cut < file.length; cut++) {
      const e = refusal(readTrace(file.subarray(0, cut), 'cut.wrctrace'));
      expect(e.kind, `cut at ${cut}`).toBe('Truncated');
      expect(e.message).toBe(`cut.wrctrace is truncated: it ends inside ${inside(cut)}; the file is incomplete`);
    }
  });

  it('finds a damaged byte in each section by its CRC-32', () => {
    const file = valid();
    const starts = sectionStarts(file);
    const names = ['meta', 'samples', 'messages', 'end'];
    starts.forEach((start, k) => {
      // In the tag, in the body (not for the empty end) and in the CRC itself.
      const next = starts[k + 1] ?? file.length;
      for (const at of [start + 1, k < 3 ? start + 14 : start + 2, next - 1]) {
        const bad = file.slice();
        bad[at] = (bad[at] as number) ^ 0x40;
        const e = refusal(readTrace(bad, 'bad.wrctrace'));
        expect(e.kind, `byte ${at}`).toBe('Corrupt');
        expect(e.message).toBe(`bad.wrctrace is corrupt: its ${names[k]} section fails its CRC-32 check`);
      }
    });
  });

  it('calls a section length above 2^32 corrupt', () => {
    const body = metaBody(META);
    const e = refusal(readTrace(traceBytes([section('META', body, { length: 2 ** 32 + 1 })])));
    expect(e.kind).toBe('Corrupt');
    expect(e.message).toContain('its meta section fails its CRC-32 check');
  });

  it('refuses sections out of order, with their right CRC', () => {
    const e = refusal(readTrace(withSections(samples(), meta(), messages(), end())));
    expect(e.kind).toBe('Invalid');
    expect(e.message).toBe('the file is not a valid trace: the meta section (tag "META") was expected, found tag "SMPL"');
    const noEnd = refusal(readTrace(withSections(meta(), samples(), messages(), ['DONE', new Uint8Array(0)])));
    expect(noEnd.message).toContain('the end section (tag "END\\0") was expected, found tag "DONE"');
  });

  it('refuses content that breaks a rule of the format', () => {
    const cases: [string, Uint8Array, string][] = [
      [
        '17 axes',
        withSections(['META', metaBody({ ...META, axisNames: Array.from({ length: 17 }, (_, i) => `a${i}`) })], samples(), messages(), end()),
        'it has 17 axes; a trace has at most 16',
      ],
      [
        'a clock code of 2',
        (() => {
          const body = metaBody(META);
          // wrc_version and reason, then the clock byte.
          body[4 + 5 + 4 + META.reason.length] = 2;
          return withSections(['META', body], samples(), messages(), end());
        })(),
        'its clock code is 2; it is 0 or 1',
      ],
      [
        'a byte after the meta',
        withSections(['META', Uint8Array.from([...metaBody(META), 0])], samples(), messages(), end()),
        'its meta section has 1 bytes after its last field',
      ],
      [
        'a reason that is not UTF-8',
        (() => {
          const body = metaBody({ ...META, reason: 'ab' });
          body[4 + 5 + 4] = 0xff;
          return withSections(['META', body], samples(), messages(), end());
        })(),
        'reason is not UTF-8',
      ],
      [
        'a state name count larger than the section',
        (() => {
          const body = metaBody({ ...META, axisNames: [], stateNames: [] });
          // wrc_version, reason, clock, period, axis count 0: then the state name count.
          new DataView(body.buffer).setUint32(4 + 5 + 4 + META.reason.length + 1 + 8 + 4, 1_000_000, true);
          return withSections(['META', body], ['SMPL', samplesBody([], 0)], messages(), end());
        })(),
        'its meta section says 1000000 state names, but holds room for at most',
      ],
      [
        'a sample count that does not fit the body',
        withSections(meta(), ['SMPL', samplesBody(SAMPLES, 3, 6)], messages(), end()),
        'its samples section says 6 samples of 77 bytes but holds 385 bytes',
      ],
      [
        'a message count larger than the section',
        withSections(meta(), samples(), ['MESG', messagesBody(MESSAGES, 1000)], end()),
        'its messages section says 1000 messages, but holds room for at most',
      ],
      [
        'a message direction of 4',
        (() => {
          const body = messagesBody(MESSAGES.slice(0, 1));
          body[8 + 8] = 4;
          return withSections(meta(), samples(), ['MESG', body], end());
        })(),
        'a message has direction code 4; it is 0 to 3',
      ],
      [
        'a message direction of 255',
        withSections(meta(), samples(), ['MESG', messagesBody([{ tNs: 1, direction: 255, line: '' }])], end()),
        'a message has direction code 255; it is 0 to 3',
      ],
      [
        'a line longer than 256 bytes',
        withSections(meta(), samples(), ['MESG', messagesBody([{ tNs: 1, direction: 'request', line: 'y'.repeat(257) }])], end()),
        'a message is 257 bytes long; a message keeps at most 256',
      ],
      [
        'a message cut short',
        (() => {
          const body = messagesBody(MESSAGES.slice(0, 1));
          return withSections(meta(), samples(), ['MESG', body.subarray(0, body.length - 3)], end());
        })(),
        'its messages section ends inside a message (13 bytes wanted, 10 left)',
      ],
      [
        'an end section with a body',
        withSections(meta(), samples(), messages(), ['END\0', Uint8Array.of(1)]),
        'its end section has 1 bytes; it has none',
      ],
    ];
    for (const [what, bytes, reason] of cases) {
      const e = refusal(readTrace(bytes, 'x.wrctrace'));
      expect(e.kind, what).toBe('Invalid');
      expect(e.message, what).toContain(`x.wrctrace is not a valid trace: ${reason}`);
    }
  });

  it('never throws, whatever the bytes (seeded mutations of a valid file)', () => {
    const file = valid();
    let seed = 12345;
    const rnd = (n: number): number => {
      seed = (Math.imul(seed, 1103515245) + 12345) >>> 0;
      return seed % n;
    };
    const kinds = new Set<string>();
    for (let i = 0; i < 2000; i++) {
      const bad = file.slice(0, file.length - rnd(4));
      for (let k = 1 + rnd(4); k > 0; k--) bad[rnd(bad.length)] = rnd(256);
      const r = readTrace(bad);
      kinds.add(r.ok ? 'ok' : r.error.kind);
    }
    expect(kinds.has('Corrupt')).toBe(true);
    expect(kinds.has('Truncated')).toBe(true);
  });
});

describe('scrubbing', () => {
  const t = (): Trace => trace(readTrace(valid()));

  it('finds the sample at or before a time', () => {
    expect(t().samples.indexAt(0)).toBe(0);
    expect(t().samples.indexAt(1_000_000_000)).toBe(0);
    expect(t().samples.indexAt(1_019_999_999)).toBe(1);
    expect(t().samples.indexAt(1_020_000_000)).toBe(2);
    expect(t().samples.indexAt(9e18)).toBe(4);
  });

  it('lists the messages within the window, the current one the last at or before the time', () => {
    const sorted = byTime([...t().messages].reverse());
    expect(sorted.map((m) => m.tNs)).toEqual([1_015_000_000, 1_016_000_000, 1_020_000_000, 1_030_000_000]);
    expect(messagesNear(sorted, 1_016_000_000, 1_000_000)).toEqual({ from: 0, to: 2, current: 1 });
    expect(messagesNear(sorted, 1_019_000_000, 1_000_000)).toEqual({ from: 2, to: 3, current: null });
    expect(messagesNear(sorted, 1_020_000_000, 1e9)).toEqual({ from: 0, to: 4, current: 2 });
    expect(messagesNear(sorted, 0, 1e9)).toEqual({ from: 0, to: 0, current: null });
    expect(messagesNear(sorted, 5e9, 1e9)).toEqual({ from: 4, to: 4, current: null });
  });

  it('keeps lines of one time in file order', () => {
    const same = [0, 1, 2].map((k) => ({ tNs: 5, direction: 'request' as const, source: 0, client: 0, truncated: false, line: `${k}` }));
    expect(byTime([{ ...same[0]!, tNs: 9 }, ...same]).map((m) => m.line)).toEqual(['0', '1', '2', '0']);
  });

  it('shows a request, a reply, a client connecting and a connection closing', () => {
    const m = (direction: TraceMessage['direction'], line = '', truncated = false): TraceMessage => ({
      tNs: 0,
      direction,
      source: 0,
      client: 3,
      truncated,
      line,
    });
    expect(describeMessage(m('request', '1 HOME'))).toEqual({ arrow: '→', text: '1 HOME', title: 'received from host client 3' });
    expect(describeMessage(m('reply', 'ACK 1'))).toEqual({ arrow: '←', text: 'ACK 1', title: 'sent to host client 3' });
    expect(describeMessage(m('request', 'x'.repeat(256), true))).toEqual({
      arrow: '→',
      text: `${'x'.repeat(256)}…`,
      title: 'received from host client 3; longer than 256 bytes, cut',
    });
    expect(describeMessage(m('opened'))).toEqual({ arrow: '⇢', text: 'client 3 connected', title: 'host client 3 connected' });
    const closed = describeMessage({ ...m('closed'), source: 1, client: 7 });
    expect(closed.arrow).toBe('⇠');
    expect(closed.text).toBe('client 7 closed');
    expect(closed.title).toBe('gui client 7: its connection closed (by the client or by the controller)');
    // As the list draws them: arrow and source, then the text.
    expect(`${describeMessage(m('opened')).arrow} ${sourceName(0)} ${describeMessage(m('opened')).text}`).toBe('⇢ host client 3 connected');
    expect(`${closed.arrow} ${sourceName(0)} ${describeMessage(m('closed')).text}`).toBe('⇠ host client 3 closed');
  });

  it('formats I/O words and source names', () => {
    expect(hex32(0xdeadbeef)).toBe('0xdeadbeef');
    expect(hex32(4)).toBe('0x00000004');
    expect(hex32(-1)).toBe('0xffffffff');
    expect([0, 1, 2, 3, 255, 9].map(sourceName)).toEqual(['host', 'gui', 'pendant', 'program', 'event', 'source 9']);
  });
});
