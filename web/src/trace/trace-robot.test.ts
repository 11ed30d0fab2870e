import { describe, expect, it } from 'vitest';
import defaultToml from '../../../config/default.toml?raw';
import dualBladeToml from '../../../config/dual-blade.toml?raw';
import { encodeTrace } from '../../e2e/trace-fixture.mjs';
import type { RobotInfo } from '../protocol/bus';
import { armAxes, armPose } from '../view3d/sim-kinematics';
import { readTrace, type Trace } from './trace';
import { ConfigTextError, positionsAt, robotFromConfigToml, traceRobot } from './trace-robot';

const LIVE: RobotInfo = {
  name: 'live-robot',
  link1: 250,
  link2: 250,
  hand: 10,
  periodMs: 10,
  inputs: 32,
  outputs: 32,
  axes: [
    { index: 1, name: 'z', role: 'z', unit: 'mm', ppu: 100, min: 0, max: 300, home: 5 },
    { index: 2, name: 'j1', role: 'shoulder', unit: 'deg', ppu: 500, min: -180, max: 180, home: 0 },
  ],
};

function trace(spec: Parameters<typeof encodeTrace>[0]): Trace {
  const r = readTrace(encodeTrace(spec));
  if (!r.ok) throw new Error(r.error.message);
  return r.trace;
}

describe('robotFromConfigToml', () => {
  it('reads the robot and its axes from the default configuration', () => {
    const r = robotFromConfigToml(defaultToml);
    expect(r).toMatchObject({ name: 'paper-300mm', link1: 200, link2: 200, hand: 0, periodMs: 10 });
    expect(r.axes.map((a) => [a.index, a.name, a.role, a.unit, a.ppu, a.home])).toEqual([
      [1, 'j1', 'shoulder', 'deg', 1000, -75],
      [2, 'j2', 'elbow', 'deg', 1000, 150],
      [3, 'j3', 'wrist', 'deg', 1000, -75],
      [4, 'z', 'z', 'mm', 1000, 0],
    ]);
  });

  it("reads blade B of a dual-blade robot's configuration, none otherwise", () => {
    expect(robotFromConfigToml(defaultToml).bladeB).toBeNull();
    expect(robotFromConfigToml(dualBladeToml)).toMatchObject({ hand: 0, bladeB: -30 });
    const base = '[robot]\nlink1_mm = 1\nlink2_mm = 1\n[[axis]]\nname = "a"\npulses_per_unit = 1\n';
    expect(robotFromConfigToml(`${base}[hand.blade_b]\nz_offset_mm = 25`).bladeB).toBe(25);
    expect(robotFromConfigToml(`${base}[hand.blade_b]\nz_offset_mm = "x"`).bladeB).toBeNull();
  });

  it('says what is missing or broken', () => {
    const cases: [string, RegExp][] = [
      ['robot = [', /^it is not TOML \(line 1, column/],
      ['[motion]\nperiod_ms = 10', /^it has no \[robot\] table$/],
      ['[robot]\nlink1_mm = 1\nlink2_mm = 1', /^it has no \[\[axis\]\] table$/],
      ['[robot]\nlink2_mm = 1\n[[axis]]\nname = "a"\npulses_per_unit = 1', /^robot\.link1_mm is missing$/],
      ['[robot]\nlink1_mm = 1\nlink2_mm = 1\n[[axis]]\nname = "a"', /^axis\[1\]\.pulses_per_unit is missing$/],
      ['[robot]\nlink1_mm = 1\nlink2_mm = 1\n[[axis]]\nname = "a"\npulses_per_unit = "x"', /^axis\[1\]\.pulses_per_unit is not a number$/],
      ['[robot]\nlink1_mm = 1\nlink2_mm = 1\n[[axis]]\nname = "a"\npulses_per_unit = 0', /^axis\[1\]\.pulses_per_unit is 0; it is above 0$/],
      ['[robot]\nlink1_mm = 1\nlink2_mm = 1\n[[axis]]\npulses_per_unit = 1', /^axis\[1\]\.name is missing$/],
    ];
    for (const [text, want] of cases) {
      expect(() => robotFromConfigToml(text), text).toThrow(ConfigTextError);
      expect(() => robotFromConfigToml(text), text).toThrow(want);
    }
  });
});

describe('traceRobot and positionsAt', () => {
  it("draws a trace with its own robot: pulses / pulses_per_unit, matched by axis name", () => {
    // The trace records its axes in another order than the configuration, and one more.
    const t = trace({
      meta: { axisNames: ['z', 'j1', 'aux', 'j2', 'j3'], configToml: defaultToml },
      samples: [
        { tNs: 0, actual: [0, -75_000, 7, 150_000, -75_000] },
        { tNs: 10_000_000, actual: [12_500, 30_000, 7, -45_250, 15_000] },
      ],
    });
    const r = traceRobot(t.meta, LIVE);
    if (!r.ok) throw new Error(r.reason);
    expect(r.value.note).toBe('');
    expect(r.value.robot.name).toBe('paper-300mm');
    expect(r.value.traceAxis).toEqual([1, 3, 4, 0]);
    expect(positionsAt(r.value, t.samples, 0)).toEqual([-75, 150, -75, 0]);
    expect(positionsAt(r.value, t.samples, 1)).toEqual([30, -45.25, 15, 12.5]);
    // As the 3D view poses the arm from them.
    expect(armPose(armAxes(r.value.robot), positionsAt(r.value, t.samples, 1))).toEqual({ j1: 30, j2: -45.25, j3: 15, z: 12.5 });
  });

  it('falls back to the live robot when the trace carries no configuration, and says so', () => {
    const t = trace({ meta: { axisNames: ['j1', 'j2'], configToml: '' }, samples: [{ tNs: 0, actual: [1000, 5] }] });
    const r = traceRobot(t.meta, LIVE);
    if (!r.ok) throw new Error(r.reason);
    expect(r.value.robot).toBe(LIVE);
    expect(r.value.note).toBe("the trace carries no configuration; drawn with the live robot's axes");
    // z is not in the trace: drawn at its home.
    expect(positionsAt(r.value, t.samples, 0)).toEqual([5, 2]);

    const broken = traceRobot({ axisNames: ['j1'], configToml: 'robot = [' }, LIVE);
    expect(broken.ok && broken.value.note).toMatch(/^the trace's configuration cannot be used: it is not TOML/);
  });

  it('refuses when no robot or no common axis is known', () => {
    expect(traceRobot({ axisNames: ['j1'], configToml: '' }, null)).toEqual({
      ok: false,
      reason: 'the trace carries no configuration, and the live robot is not known',
    });
    expect(traceRobot({ axisNames: ['a', 'b'], configToml: '' }, LIVE)).toEqual({
      ok: false,
      reason: "none of the trace's axes (a, b) is an axis of robot live-robot (z, j1)",
    });
  });
});
