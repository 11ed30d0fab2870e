import { describe, expect, it } from 'vitest';
import type { SimSample } from './bus';
import { PulseRate, StreamStats, decodeSample, encodeSample } from './stream';

// The shared test vector written by the Rust encoder (empty until it exists).
const VECTORS = import.meta.glob<string>('../../../crates/wrc-protocol/tests/vectors/sim_stream_v1.json', {
  eager: true,
  query: '?raw',
  import: 'default',
});
const VECTOR: string | undefined = Object.values(VECTORS)[0];

/** A datagram built by hand, field by field, as docs/simulator-stream.md lays it out. */
function handMade(): ArrayBuffer {
  const n = 4;
  const buf = new ArrayBuffer(72 + 16 * n);
  const v = new DataView(buf);
  [0x57, 0x52, 0x43, 0x53].forEach((b, i) => v.setUint8(i, b));
  v.setUint16(4, 1, true);
  v.setUint8(6, n);
  v.setUint8(7, 1); // MOVING
  v.setBigUint64(8, 123456789n, true);
  v.setBigUint64(16, 1_000_000_007n, true);
  v.setUint8(24, 1);
  v.setUint32(28, 0xdeadbeef, true);
  v.setUint32(32, 5, true);
  v.setFloat64(40, 123.5, true);
  v.setFloat64(48, -45.25, true);
  v.setFloat64(56, 10, true);
  v.setFloat64(64, 90.5, true);
  const pos = [-75, 150, -75.125, 12.5];
  const pul = [-75000n, 150000n, -75125n, 12500n];
  pos.forEach((p, i) => v.setFloat64(72 + 8 * i, p, true));
  pul.forEach((p, i) => v.setBigInt64(72 + 8 * n + 8 * i, p, true));
  return buf;
}

function withByte(buf: ArrayBuffer, offset: number, byte: number): ArrayBuffer {
  const b = buf.slice(0);
  new DataView(b).setUint8(offset, byte);
  return b;
}

function sample(seq: number, timeNs: number, pulses: number[]): SimSample {
  return {
    seq,
    timeNs,
    state: 'MOVING',
    homed: true,
    inputs: 0,
    outputs: 0,
    x: 0,
    y: 0,
    z: 0,
    yaw: 0,
    positions: pulses.map((p) => p / 1000),
    pulses,
  };
}

describe('decodeSample', () => {
  it('decodes a hand-made version 1 datagram', () => {
    const buf = handMade();
    expect(buf.byteLength).toBe(136);
    expect(Array.from(new Uint8Array(buf, 0, 8))).toEqual([0x57, 0x52, 0x43, 0x53, 1, 0, 4, 1]);
    expect(decodeSample(buf)).toEqual({
      seq: 123456789,
      timeNs: 1_000_000_007,
      state: 'MOVING',
      homed: true,
      inputs: 0xdeadbeef,
      outputs: 5,
      x: 123.5,
      y: -45.25,
      z: 10,
      yaw: 90.5,
      positions: [-75, 150, -75.125, 12.5],
      pulses: [-75000, 150000, -75125, 12500],
    });
  });

  it('decodes every state, homed 0, one axis and sixteen axes', () => {
    // docs/simulator-stream.md: 0 IDLE, 1 MOVING, 2 STOPPING, 3 ERROR, 4 ESTOP, 5 HELD.
    const states = ['IDLE', 'MOVING', 'STOPPING', 'ERROR', 'ESTOP', 'HELD'] as const;
    states.forEach((st, k) => {
      expect(decodeSample(withByte(handMade(), 7, k))?.state).toBe(st);
    });
    expect(decodeSample(withByte(handMade(), 24, 0))?.homed).toBe(false);
    for (const n of [1, 16]) {
      const s = sample(7, 8, Array.from({ length: n }, (_, i) => i * 1000 - 3));
      const buf = encodeSample(s);
      expect(buf.byteLength).toBe(72 + 16 * n);
      expect(decodeSample(buf)).toEqual(s);
    }
  });

  it('decodes state byte 5 as HELD and encodes HELD as 5', () => {
    expect(decodeSample(withByte(handMade(), 7, 5))?.state).toBe('HELD');
    const held: SimSample = { ...sample(42, 43, [1000, -2000, 3000, 4000]), state: 'HELD' };
    const buf = encodeSample(held);
    expect(new DataView(buf).getUint8(7)).toBe(5);
    expect(decodeSample(buf)).toEqual(held);
  });

  it('keeps u64 and i64 values exact up to 2^53 and rounds beyond like JSON.parse', () => {
    const buf = handMade();
    const v = new DataView(buf);
    v.setBigUint64(8, 2n ** 53n - 1n, true);
    v.setBigUint64(16, 0x0102030405060708n, true);
    v.setBigInt64(72 + 32, -(2n ** 53n) + 1n, true);
    v.setBigInt64(72 + 40, -1n, true);
    const s = decodeSample(buf);
    expect(s?.seq).toBe(Number.MAX_SAFE_INTEGER);
    expect(s?.timeNs).toBe(JSON.parse('72623859790382856'));
    expect(s?.pulses[0]).toBe(-Number.MAX_SAFE_INTEGER);
    expect(s?.pulses[1]).toBe(-1);
  });

  it('round-trips through encodeSample', () => {
    const s: SimSample = {
      ...sample(99, 5_000_000_000, [1, -2, 3, -4000000000]),
      state: 'ESTOP',
      homed: false,
      inputs: 0xffffffff,
      outputs: 0x80000000,
      x: -1e-3,
      y: 399.99,
      z: 300,
      yaw: -179.5,
    };
    expect(decodeSample(encodeSample(s))).toEqual(s);
  });

  it('rejects what version 1 does not allow, without throwing', () => {
    const good = handMade();
    expect(decodeSample(good)).not.toBeNull();
    const bad: [string, ArrayBuffer][] = [
      ['empty', new ArrayBuffer(0)],
      ['header only', good.slice(0, 72)],
      ['too short', good.slice(0, 71)],
      ['one byte short', good.slice(0, 135)],
      ['one byte long', (() => {
        const b = new Uint8Array(137);
        b.set(new Uint8Array(good));
        return b.buffer;
      })()],
      ['bad magic', withByte(good, 0, 0x58)],
      ['bad magic (last byte)', withByte(good, 3, 0x54)],
      ['version 2', withByte(good, 4, 2)],
      ['version 0', withByte(good, 4, 0)],
      ['version 257', withByte(good, 5, 1)],
      ['0 axes', withByte(good, 6, 0)],
      ['17 axes', withByte(good, 6, 17)],
      ['3 axes (length mismatch)', withByte(good, 6, 3)],
      ['5 axes (length mismatch)', withByte(good, 6, 5)],
      ['state 6', withByte(good, 7, 6)],
      ['state 255', withByte(good, 7, 255)],
      ['homed 2', withByte(good, 24, 2)],
    ];
    for (const o of [25, 26, 27, 36, 37, 38, 39]) bad.push([`reserved byte ${o}`, withByte(good, o, 1)]);
    for (const [why, buf] of bad) {
      expect(decodeSample(buf), why).toBeNull();
    }
    // Not an ArrayBuffer at all.
    expect(decodeSample(null as unknown as ArrayBuffer)).toBeNull();
    expect(decodeSample('WRCS' as unknown as ArrayBuffer)).toBeNull();
    expect(decodeSample({ byteLength: 136 } as unknown as ArrayBuffer)).toBeNull();
  });

  it('passes floating-point values on as sent (NaN, infinities)', () => {
    const buf = handMade();
    const v = new DataView(buf);
    v.setFloat64(40, NaN, true);
    v.setFloat64(48, Infinity, true);
    const s = decodeSample(buf);
    expect(s?.x).toBeNaN();
    expect(s?.y).toBe(Infinity);
  });

  it.skipIf(VECTOR === undefined)('decodes the shared test vector of the Rust encoder', () => {
    const vec = JSON.parse(VECTOR ?? '') as {
      hex: string;
      decoded: {
        seq: number;
        timestamp_ns: number;
        state: string;
        homed: boolean;
        inputs: number;
        outputs: number;
        x: number;
        y: number;
        z: number;
        yaw: number;
        positions: number[];
        pulses: number[];
      };
    };
    const hex = vec.hex.replace(/\s+/g, '');
    const bytes = new Uint8Array(hex.length / 2);
    for (let i = 0; i < bytes.length; i++) bytes[i] = parseInt(hex.slice(2 * i, 2 * i + 2), 16);
    const d = vec.decoded;
    expect(decodeSample(bytes.buffer)).toEqual({
      seq: d.seq,
      timeNs: d.timestamp_ns,
      state: d.state,
      homed: d.homed,
      inputs: d.inputs,
      outputs: d.outputs,
      x: d.x,
      y: d.y,
      z: d.z,
      yaw: d.yaw,
      positions: d.positions,
      pulses: d.pulses,
    });
    // And the vector's datagram is what encodeSample writes for the same values.
    const s = decodeSample(bytes.buffer);
    if (s && Number.isSafeInteger(s.seq) && Number.isSafeInteger(s.timeNs)) {
      expect(new Uint8Array(encodeSample(s))).toEqual(bytes);
    }
  });
});

describe('PulseRate', () => {
  it('gives the pulse difference per period between consecutive samples', () => {
    const r = new PulseRate();
    expect(r.push(sample(10, 0, [0, 100]))).toBeNull();
    const p = r.push(sample(11, 10e6, [5, 90]));
    expect(p).toEqual({ seq: 11, timeNs: 10e6, perPeriod: [5, -10], periods: 1, lost: 0 });
  });

  it('averages over the periods elapsed on a sequence gap and counts the lost datagrams', () => {
    const r = new PulseRate();
    r.push(sample(10, 0, [0]));
    const p = r.push(sample(14, 40e6, [40]));
    expect(p?.perPeriod).toEqual([10]);
    expect(p?.periods).toBe(4);
    expect(p?.lost).toBe(3);
  });

  it('counts Pulse Generator periods from the timestamps when the period is known', () => {
    const r = new PulseRate(10);
    r.push(sample(1, 0, [0]));
    // Stream at 20 ms, Pulse Generator at 10 ms: 2 periods per datagram.
    expect(r.push(sample(2, 20.3e6, [30]))?.perPeriod).toEqual([15]);
    // Jitter does not change the count of periods.
    expect(r.push(sample(3, 39.6e6, [50]))?.periods).toBe(2);
    // A stall with no sequence gap (the sender was late) is still a break when long.
    const stall = r.push(sample(4, 39.6e6 + 2e9, [60]));
    expect(stall?.perPeriod).toEqual([null]);
    expect(stall?.lost).toBe(0);
  });

  it('breaks the series on a long gap and restarts on a sequence that goes back', () => {
    const r = new PulseRate(0, 5);
    r.push(sample(1, 0, [0, 0]));
    const p = r.push(sample(100, 990e6, [990, 0]));
    expect(p?.perPeriod).toEqual([null, null]);
    expect(p?.lost).toBe(98);
    expect(r.push(sample(3, 0, [0, 0]))).toBeNull(); // controller restarted
    expect(r.push(sample(3, 0, [0, 0]))).toBeNull(); // repeated
    expect(r.push(sample(4, 10e6, [7, 0]))?.perPeriod).toEqual([7, 0]);
    expect(r.push(sample(5, 20e6, [7]))).toBeNull(); // axis count changed
    r.reset();
    expect(r.push(sample(6, 30e6, [7]))).toBeNull();
  });
});

describe('StreamStats', () => {
  it('counts lost datagrams and gaps, and the rate over the last second', () => {
    const st = new StreamStats(1000);
    for (let i = 0; i < 100; i++) st.push(sample(i, i * 10e6, [0]), i * 10);
    expect(st.rate(995)).toBe(100);
    st.push(sample(105, 0, [0]), 1000);
    expect(st.lost).toBe(5);
    expect(st.gaps).toBe(1);
    st.push(sample(0, 0, [0]), 1010); // restart: nothing known lost
    expect(st.lost).toBe(5);
    expect(st.rate(5000)).toBe(0);
    st.reset();
    expect([st.received, st.lost, st.gaps]).toEqual([0, 0, 0]);
  });
});
