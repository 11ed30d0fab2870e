import { describe, expect, it } from 'vitest';
import type { RobotInfo, TaskTiming } from './bus';
import {
  RollingSeries,
  binIndex,
  binLabel,
  fmtCount,
  fmtMs,
  fmtUs,
  fullBins,
  logHeight,
  maxBinIndex,
} from './plot-data';
import { armAxes, armPose, forwardTcp, homePositions, wrap180 } from './sim-kinematics';
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

const PAPER: RobotInfo = {
  name: 'paper-300mm',
  link1: 200,
  link2: 200,
  hand: 0,
  periodMs: 10,
  inputs: 32,
  outputs: 32,
  axes: [
    { index: 1, name: 'j1', role: 'shoulder', unit: 'deg', ppu: 1000, min: -180, max: 180, home: -75 },
    { index: 2, name: 'j2', role: 'elbow', unit: 'deg', ppu: 1000, min: -165, max: 165, home: 150 },
    { index: 3, name: 'j3', role: 'wrist', unit: 'deg', ppu: 1000, min: -270, max: 270, home: -75 },
    { index: 4, name: 'z', role: 'z', unit: 'mm', ppu: 1000, min: 0, max: 300, home: 0 },
  ],
};

describe('simulator kinematics', () => {
  it('finds the axes by role and follows the controller forward kinematics', () => {
    const axes = armAxes(PAPER);
    expect(axes).toEqual({ shoulder: 0, elbow: 1, wrist: 2, z: 3 });
    const home = armPose(axes, homePositions(PAPER));
    expect(home).toEqual({ j1: -75, j2: 150, j3: -75, z: 0 });
    const tcp = forwardTcp(PAPER, home);
    // Home: elbow at -75°, wrist back at 200∠-75° + 200∠75° = (2·200·cos75°, 0).
    expect(tcp.x).toBeCloseTo(400 * Math.cos((75 * Math.PI) / 180));
    expect(tcp.y).toBeCloseTo(0);
    expect(tcp.yaw).toBeCloseTo(0);
    const p = forwardTcp({ link1: 200, link2: 150, hand: 100 }, { j1: 90, j2: -90, j3: 90, z: 42 });
    expect(p.x).toBeCloseTo(150);
    expect(p.y).toBeCloseTo(300);
    expect(p.z).toBe(42);
    expect(p.yaw).toBeCloseTo(90);
  });

  it('draws robots without wrist or Z axis, with auxiliary axes and other orders', () => {
    const scara: RobotInfo = {
      ...PAPER,
      link1: 300,
      link2: 250,
      hand: 120,
      axes: [
        { index: 1, name: 'track', role: 'auxiliary', unit: 'mm', ppu: 100, min: 0, max: 1000, home: 0 },
        { index: 2, name: 'a', role: 'shoulder', unit: 'deg', ppu: 100, min: -180, max: 180, home: 10 },
        { index: 3, name: 'b', role: 'elbow', unit: 'deg', ppu: 100, min: -180, max: 180, home: 20 },
      ],
    };
    const axes = armAxes(scara);
    expect(axes).toEqual({ shoulder: 1, elbow: 2, wrist: null, z: null });
    expect(armPose(axes, [500, 30, 60])).toEqual({ j1: 30, j2: 60, j3: 0, z: 0 });
    // Short or non-finite positions read as 0.
    expect(armPose(axes, [1, NaN])).toEqual({ j1: 0, j2: 0, j3: 0, z: 0 });
    expect(forwardTcp(scara, { j1: 0, j2: 0, j3: 0, z: 0 }).x).toBeCloseTo(670);
  });

  it('wraps yaw into (-180, 180]', () => {
    expect(wrap180(180)).toBe(180);
    expect(wrap180(-180)).toBe(180);
    expect(wrap180(270)).toBe(-90);
    expect(wrap180(-450)).toBe(-90);
  });
});
