// Simulator stream: decoding of the binary datagrams (docs/simulator-stream.md, version 1)
// that `wrc ui` forwards verbatim as WebSocket binary frames, and small helpers that turn
// successive samples into pulses per period and stream statistics.

import type { RobotState, SimSample } from './bus';
import { getI64, getU64, setI64, setU64 } from '../le64';

/** `WRCS`. */
const MAGIC = [0x57, 0x52, 0x43, 0x53];
/** The layout version this decoder knows. */
export const SIM_STREAM_VERSION = 1;
/** Header length [bytes]; each axis adds 16 (an f64 position and an i64 pulse count). */
export const SIM_HEADER_LEN = 72;
export const SIM_AXIS_LEN = 16;
export const SIM_MAX_AXES = 16;

/** The stream's state byte: index 0 to 5 (`HELD` is 5, after `ESTOP`; names as in `STATUS`). */
export const SIM_STATES: readonly RobotState[] = ['IDLE', 'MOVING', 'STOPPING', 'ERROR', 'ESTOP', 'HELD'];

/**
 * Decode one version 1 datagram. Returns null for anything that is not exactly a valid
 * version 1 datagram (magic, version, axis count 1-16, exact length, state 0-5, homed 0/1,
 * reserved bytes zero); never throws.
 *
 * The u64 sequence and timestamp and the i64 pulse counts become JS numbers: exact up to
 * 2^53, rounded to the nearest double beyond (as `JSON.parse` would do).
 */
export function decodeSample(buf: ArrayBuffer): SimSample | null {
  try {
    return decodeV1(buf);
  } catch {
    return null;
  }
}

function decodeV1(buf: ArrayBuffer): SimSample | null {
  if (buf === null || typeof buf !== 'object' || typeof buf.byteLength !== 'number') return null;
  const len = buf.byteLength;
  if (len < SIM_HEADER_LEN) return null;
  const v = new DataView(buf);
  for (let i = 0; i < 4; i++) if (v.getUint8(i) !== MAGIC[i]) return null;
  if (v.getUint16(4, true) !== SIM_STREAM_VERSION) return null;
  const n = v.getUint8(6);
  if (n < 1 || n > SIM_MAX_AXES) return null;
  if (len !== SIM_HEADER_LEN + SIM_AXIS_LEN * n) return null;
  const stateNo = v.getUint8(7);
  const state = SIM_STATES[stateNo];
  if (state === undefined) return null;
  const homedByte = v.getUint8(24);
  if (homedByte > 1) return null;
  for (const o of [25, 26, 27, 36, 37, 38, 39]) if (v.getUint8(o) !== 0) return null;

  const u64 = (o: number): number => getU64(v, o);
  const i64 = (o: number): number => getI64(v, o);

  const positions = new Array<number>(n);
  const pulses = new Array<number>(n);
  for (let i = 0; i < n; i++) {
    positions[i] = v.getFloat64(SIM_HEADER_LEN + 8 * i, true);
    pulses[i] = i64(SIM_HEADER_LEN + 8 * n + 8 * i);
  }
  return {
    seq: u64(8),
    timeNs: u64(16),
    state,
    homed: homedByte === 1,
    inputs: v.getUint32(28, true),
    outputs: v.getUint32(32, true),
    x: v.getFloat64(40, true),
    y: v.getFloat64(48, true),
    z: v.getFloat64(56, true),
    yaw: v.getFloat64(64, true),
    positions,
    pulses,
  };
}

/**
 * Encode a sample as a version 1 datagram: the inverse of `decodeSample`, for tests and
 * for driving the GUI without a controller. Integers must be exact JS integers (< 2^53).
 */
export function encodeSample(s: SimSample): ArrayBuffer {
  const n = s.positions.length;
  const buf = new ArrayBuffer(SIM_HEADER_LEN + SIM_AXIS_LEN * n);
  const v = new DataView(buf);
  MAGIC.forEach((b, i) => v.setUint8(i, b));
  v.setUint16(4, SIM_STREAM_VERSION, true);
  v.setUint8(6, n);
  v.setUint8(7, Math.max(0, SIM_STATES.indexOf(s.state)));
  setU64(v, 8, s.seq);
  setU64(v, 16, s.timeNs);
  v.setUint8(24, s.homed ? 1 : 0);
  v.setUint32(28, s.inputs >>> 0, true);
  v.setUint32(32, s.outputs >>> 0, true);
  v.setFloat64(40, s.x, true);
  v.setFloat64(48, s.y, true);
  v.setFloat64(56, s.z, true);
  v.setFloat64(64, s.yaw, true);
  for (let i = 0; i < n; i++) {
    v.setFloat64(SIM_HEADER_LEN + 8 * i, s.positions[i] ?? 0, true);
    setI64(v, SIM_HEADER_LEN + 8 * n + 8 * i, s.pulses[i] ?? 0);
  }
  return buf;
}

/** One point of the pulses-per-period series. */
export interface PulseRatePoint {
  /** Sequence number of the sample that ends the interval. */
  seq: number;
  /** Controller time of that sample [ns]. */
  timeNs: number;
  /**
   * Pulses per period of each axis over the interval since the previous sample; null for
   * every axis when the interval is a long gap (more than `maxGap` datagrams lost, or more
   * than `maxGap + 1` periods by the timestamps): the plot shows a break.
   */
  perPeriod: (number | null)[];
  /** Periods the interval spans (1 without loss). */
  periods: number;
  /** Datagrams lost in the interval (sequence gap − 1; 0 without loss). */
  lost: number;
}

/**
 * Turns successive samples into output pulses per period per axis (the paper's Fig. 7 and 8).
 *
 * The value for an interval is the difference of `pulses` between two received samples
 * divided by the number of periods the interval spans:
 * - with `periodMs` (the Pulse Generator period, `RobotInfo.periodMs`) and increasing
 *   timestamps, periods = round(Δt / period), at least 1 — so the value stays "per Pulse
 *   Generator period" even if the stream's rate differs from it;
 * - otherwise periods = the sequence difference (one datagram per period).
 *
 * On a sequence gap (lost datagrams) the difference is thus averaged over the periods elapsed
 * and `lost` says how many datagrams were missing. A gap longer than `maxGap` datagrams (or
 * periods, by the timestamps) is not averaged: its point has null values (a break in the
 * plot). A sequence that goes
 * backwards or repeats, or a change of axis count, restarts the series (the controller was
 * restarted): no point is produced for that sample.
 */
export class PulseRate {
  private prev: SimSample | null = null;

  constructor(
    public periodMs = 0,
    public maxGap = 50,
  ) {}

  reset(): void {
    this.prev = null;
  }

  push(s: SimSample): PulseRatePoint | null {
    const prev = this.prev;
    this.prev = s;
    if (prev === null) return null;
    const dSeq = s.seq - prev.seq;
    if (!(dSeq >= 1) || s.pulses.length !== prev.pulses.length) return null;
    const lost = dSeq - 1;
    let periods = dSeq;
    const dt = s.timeNs - prev.timeNs;
    if (this.periodMs > 0 && dt > 0) periods = Math.max(1, Math.round(dt / (this.periodMs * 1e6)));
    const long = lost > this.maxGap || periods > this.maxGap + 1;
    const perPeriod: (number | null)[] = s.pulses.map((p, i) =>
      long ? null : (p - (prev.pulses[i] ?? p)) / periods,
    );
    return { seq: s.seq, timeNs: s.timeNs, perPeriod, periods, lost };
  }
}

/** Received/lost datagram counts and the receive rate, for the simulator overlay. */
export class StreamStats {
  received = 0;
  /** Datagrams missing from the sequence since the last reset. */
  lost = 0;
  /** Sequence gaps (each run of missing datagrams counts once). */
  gaps = 0;
  private lastSeq: number | null = null;
  private times: number[] = [];

  constructor(private readonly windowMs = 1000) {}

  reset(): void {
    this.received = 0;
    this.lost = 0;
    this.gaps = 0;
    this.lastSeq = null;
    this.times = [];
  }

  /** Count a sample; `nowMs` is the receive time (e.g. `performance.now()`). */
  push(s: SimSample, nowMs: number): void {
    this.received++;
    if (this.lastSeq !== null) {
      const d = s.seq - this.lastSeq;
      if (d > 1) {
        this.lost += d - 1;
        this.gaps++;
      }
      // d <= 0: the controller restarted its sequence; nothing was lost that we know of.
    }
    this.lastSeq = s.seq;
    this.times.push(nowMs);
    this.trim(nowMs);
  }

  /** Samples per second over the last window. */
  rate(nowMs: number): number {
    this.trim(nowMs);
    return (this.times.length * 1000) / this.windowMs;
  }

  private trim(nowMs: number): void {
    const from = nowMs - this.windowMs;
    let k = 0;
    while (k < this.times.length && (this.times[k] as number) <= from) k++;
    if (k > 0) this.times.splice(0, k);
  }
}
