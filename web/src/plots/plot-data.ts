// Data helpers of the Plots panel, free of the DOM so that they can be unit-tested:
// the rolling window of the pulses-per-period chart, the latency histogram bins and the
// number formats of the task table.

import type { TaskTiming } from '../protocol/bus';

/** uPlot's aligned data: x values, then one array per series (null: a break). */
export type Aligned = [number[], ...(number | null)[][]];

/**
 * A rolling time window of points (x in seconds) for a fixed number of series. Points older
 * than `windowS` before the newest are dropped; a point whose x goes backwards clears the
 * window first (the controller restarted its clock). A missing value is kept as NaN (arrays of
 * plain doubles: minutes of history are no heap objects for the collector to walk) and given
 * to uPlot as null, a break.
 */
export class RollingSeries {
  private xs: number[] = [];
  private ys: number[][];
  private start = 0;

  constructor(
    readonly nSeries: number,
    public windowS: number,
  ) {
    this.ys = Array.from({ length: nSeries }, () => []);
  }

  get length(): number {
    return this.xs.length - this.start;
  }

  /** The newest x, or null when empty. */
  last(): number | null {
    return this.length > 0 ? (this.xs[this.xs.length - 1] as number) : null;
  }

  clear(): void {
    this.xs = [];
    this.ys = Array.from({ length: this.nSeries }, () => []);
    this.start = 0;
  }

  push(x: number, values: readonly (number | null)[]): void {
    const last = this.last();
    if (last !== null && x < last) this.clear();
    this.xs.push(x);
    for (let i = 0; i < this.nSeries; i++) {
      const v = values[i];
      (this.ys[i] as number[]).push(v === undefined || v === null || !Number.isFinite(v) ? NaN : v);
    }
    this.trim();
  }

  private trim(): void {
    const last = this.last();
    if (last === null) return;
    const from = last - this.windowS;
    while (this.start < this.xs.length && (this.xs[this.start] as number) < from) this.start++;
    if (this.start > 1024 && this.start * 2 > this.xs.length) {
      this.xs = this.xs.slice(this.start);
      this.ys = this.ys.map((y) => y.slice(this.start));
      this.start = 0;
    }
  }

  /** Change the window; older points are dropped at once when it shrinks. */
  setWindow(windowS: number): void {
    this.windowS = windowS;
    this.trim();
  }

  /** A copy of the window, for uPlot's `setData`. */
  data(): Aligned {
    return [this.xs.slice(this.start), ...this.ys.map((y) => gaps(y.slice(this.start)))];
  }

  /** The oldest x kept, or null when empty. */
  first(): number | null {
    return this.length > 0 ? (this.xs[this.start] as number) : null;
  }

  /** A copy of the points with `from` ≤ x ≤ `to` (and one on each side, so lines reach the edges). */
  range(from: number, to: number): Aligned {
    const lo = Math.max(this.start, this.lowerBound(from) - 1);
    const hi = Math.min(this.xs.length, this.lowerBound(to) + 2);
    if (hi <= lo) return [[], ...this.ys.map(() => [])];
    return [this.xs.slice(lo, hi), ...this.ys.map((y) => gaps(y.slice(lo, hi)))];
  }

  /** The first index at or after `start` whose x is ≥ `x`. */
  private lowerBound(x: number): number {
    let a = this.start;
    let b = this.xs.length;
    while (a < b) {
      const m = (a + b) >> 1;
      if ((this.xs[m] as number) < x) a = m + 1;
      else b = m;
    }
    return a;
  }
}

/** NaN (a missing value) as null: a break in uPlot's line. */
function gaps(values: number[]): (number | null)[] {
  return values.map((v) => (Number.isNaN(v) ? null : v));
}

/**
 * The x range a chart shows: `windowS` wide, ending at the newest point while following it
 * (`end` null), else at `end`, kept within what is kept [first, last].
 */
export function viewRange(first: number | null, last: number | null, windowS: number, end: number | null): [number, number] {
  if (first === null || last === null) return [0, windowS];
  const e = end === null ? last : Math.min(last, Math.max(first + Math.min(windowS, last - first), end));
  return [e - windowS, e];
}

/** A histogram bin for drawing: upper bound [µs] and count. */
export interface HistBin {
  upperUs: number;
  count: number;
}

/** log2 of a bin's upper bound, rounded (bins are powers of two: 1, 2, 4, … µs). */
export function binIndex(upperUs: number): number {
  return upperUs <= 1 ? 0 : Math.round(Math.log2(upperUs));
}

/**
 * Every power-of-two bin from 1 µs to `2^maxIndex` µs with its count (0 for bins the
 * controller left out), so that all rows of the table share one x axis.
 */
export function fullBins(hist: readonly [number, number][], maxIndex: number): HistBin[] {
  const bins: HistBin[] = [];
  for (let k = 0; k <= maxIndex; k++) bins.push({ upperUs: 2 ** k, count: 0 });
  for (const [u, n] of hist) {
    const k = binIndex(u);
    const b = bins[Math.min(k, maxIndex)];
    if (b) b.count += n;
  }
  return bins;
}

/** The largest bin index over the tasks, at least `minIndex` (a common axis for the table). */
export function maxBinIndex(tasks: readonly TaskTiming[], minIndex = 6): number {
  let m = minIndex;
  for (const t of tasks) for (const [u, n] of t.latHist) if (n > 0) m = Math.max(m, binIndex(u));
  return m;
}

/** Bar height of a count on a log scale, 0..1 relative to the largest count (0 for 0). */
export function logHeight(count: number, maxCount: number): number {
  if (count <= 0 || maxCount <= 0) return 0;
  return Math.log10(1 + count) / Math.log10(1 + maxCount);
}

/** A bin's label: `< 1 µs`, `1–2 µs`, `512–1024 µs`. */
export function binLabel(upperUs: number): string {
  return upperUs <= 1 ? '< 1 µs' : `${upperUs / 2}–${upperUs} µs`;
}

/** A µs value for the table: 1 decimal (none from 10 000 µs), thin-space thousands; `—` if not finite. */
export function fmtUs(v: number): string {
  if (!Number.isFinite(v)) return '—';
  const s = Math.abs(v) >= 10000 ? v.toFixed(0) : v.toFixed(1);
  return groupThousands(s);
}

/** An integer count with thin-space thousands; `—` if not finite. */
export function fmtCount(v: number): string {
  if (!Number.isFinite(v)) return '—';
  return groupThousands(Math.round(v).toString());
}

/** A configured period [ms]: as short as exact (`10`, `0.5`). */
export function fmtMs(v: number): string {
  if (!Number.isFinite(v)) return '—';
  return String(Math.round(v * 1000) / 1000);
}

function groupThousands(s: string): string {
  const neg = s.startsWith('-');
  const body = neg ? s.slice(1) : s;
  const dot = body.indexOf('.');
  const int = dot < 0 ? body : body.slice(0, dot);
  const frac = dot < 0 ? '' : body.slice(dot);
  const grouped = int.length > 4 ? int.replace(/\B(?=(\d{3})+(?!\d))/g, '\u2009') : int;
  return (neg ? '-' : '') + grouped + frac;
}
