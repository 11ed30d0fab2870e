import { describe, expect, it } from 'vitest';
import type { TaskTiming } from '../protocol/bus';
import {
  RollingSeries,
  viewRange,
  binIndex,
  binLabel,
  fmtCount,
  fmtMs,
  fmtUs,
  fullBins,
  logHeight,
  maxBinIndex,
} from './plot-data';
import { parseTaskLine } from './tasks';

describe('RollingSeries', () => {
  it('keeps the last window of points', () => {
    const r = new RollingSeries(2, 1);
    for (let i = 0; i <= 300; i++) r.push(i * 0.01, [i, -i]);
    const [x, a, b] = r.data();
    expect(x[0]).toBeCloseTo(2);
    expect(x[x.length - 1]).toBeCloseTo(3);
    expect(x.length).toBe(r.length);
    expect(a?.[a.length - 1]).toBe(300);
    expect(b?.[0]).toBe(-200);
  });

  it('stays bounded over a long run', () => {
    const r = new RollingSeries(1, 10);
    for (let i = 0; i < 100000; i++) r.push(i * 0.01, [i]);
    expect(r.length).toBe(1001);
    expect(r.data()[0].length).toBe(1001);
  });

  it('turns missing and non-finite values into nulls (breaks)', () => {
    const r = new RollingSeries(3, 10);
    r.push(0, [1, null, NaN]);
    r.push(1, [2]);
    expect(r.data()).toEqual([
      [0, 1],
      [1, 2],
      [null, null],
      [null, null],
    ]);
  });

  it('clears when time goes back, and on a shrinking window', () => {
    const r = new RollingSeries(1, 10);
    r.push(5, [1]);
    r.push(6, [2]);
    r.push(1, [3]);
    expect(r.data()).toEqual([[1], [3]]);
    for (let t = 2; t <= 10; t++) r.push(t, [t]);
    r.setWindow(2);
    expect(r.data()[0]).toEqual([8, 9, 10]);
    r.clear();
    expect(r.length).toBe(0);
    expect(r.last()).toBeNull();
  });
});

describe('latency histogram bins', () => {
  const t = parseTaskLine('TASK a prio=1 lat_hist=1:4,4:2,32:3,64:40,128:9') as TaskTiming;
  const u = parseTaskLine('TASK b prio=2 lat_hist=2048:1') as TaskTiming;

  it('spreads the bins on a common power-of-two axis', () => {
    expect(binIndex(1)).toBe(0);
    expect(binIndex(0.5)).toBe(0);
    expect(binIndex(128)).toBe(7);
    expect(maxBinIndex([t])).toBe(7);
    expect(maxBinIndex([t, u])).toBe(11);
    expect(maxBinIndex([])).toBe(6);
    const bins = fullBins(t.latHist, 7);
    expect(bins.map((b) => b.upperUs)).toEqual([1, 2, 4, 8, 16, 32, 64, 128]);
    expect(bins.map((b) => b.count)).toEqual([4, 0, 2, 0, 0, 3, 40, 9]);
    // Bins past the axis are added to the last bar.
    expect(fullBins(u.latHist, 7).map((b) => b.count)).toEqual([0, 0, 0, 0, 0, 0, 0, 1]);
  });

  it('scales counts logarithmically', () => {
    expect(logHeight(0, 100)).toBe(0);
    expect(logHeight(100, 100)).toBe(1);
    expect(logHeight(9, 999)).toBeCloseTo(1 / 3);
    expect(logHeight(5, 0)).toBe(0);
  });

  it('labels bins', () => {
    expect(binLabel(1)).toBe('< 1 µs');
    expect(binLabel(64)).toBe('32–64 µs');
  });
});

describe('table formats', () => {
  it('formats µs, counts and periods', () => {
    expect(fmtUs(3.14)).toBe('3.1');
    expect(fmtUs(9999.94)).toBe('9999.9');
    expect(fmtUs(100000.2)).toBe('100\u2009000');
    expect(fmtUs(NaN)).toBe('—');
    expect(fmtCount(1234567)).toBe('1\u2009234\u2009567');
    expect(fmtCount(1234)).toBe('1234');
    expect(fmtMs(10)).toBe('10');
    expect(fmtMs(0.5)).toBe('0.5');
  });
});

describe('history kept and a window over it', () => {
  it('range() gives the points of a window (and one beyond each edge)', () => {
    const s = new RollingSeries(1, 300);
    for (let t = 0; t <= 100; t++) s.push(t, [t * 2]);
    const [xs, ys] = s.range(10, 20);
    expect(xs).toEqual([9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21]);
    expect(ys?.[0]).toBe(18);
    expect(s.first()).toBe(0);
    expect(s.range(500, 600)[0]).toEqual([100]);
  });

  it('keeps minutes: a move made long before the window is still there', () => {
    const s = new RollingSeries(1, 300);
    for (let t = 0; t <= 240; t += 0.5) s.push(t, [t < 5 ? 100 : 0]);
    // The window shows the last 10 s; the move at 0-5 s is kept.
    expect(s.first()).toBe(0);
    expect(s.range(0, 5)[1]?.some((v) => v === 100)).toBe(true);
  });

  it('viewRange follows the newest point, or ends where the operator put it, within what is kept', () => {
    expect(viewRange(0, 240, 10, null)).toEqual([230, 240]);
    expect(viewRange(0, 240, 10, 60)).toEqual([50, 60]);
    expect(viewRange(0, 240, 10, 1)).toEqual([0, 10]);
    expect(viewRange(0, 240, 10, 999)).toEqual([230, 240]);
    expect(viewRange(null, null, 10, null)).toEqual([0, 10]);
  });
});
