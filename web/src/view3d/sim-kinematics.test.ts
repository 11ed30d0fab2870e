import { describe, expect, it } from 'vitest';
import type { RobotInfo } from '../protocol/bus';
import { armAxes, armPose, forwardTcp, homePositions, wrap180 } from './sim-kinematics';

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
