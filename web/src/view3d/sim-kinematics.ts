// Joint roles → drawn arm pose, and the forward kinematics the 3D view follows
// (crates/wrc-robot/src/kinematics.rs): angles in degrees, lengths in mm; J1 from the base
// x axis, J2 from link 1, J3 from link 2, all counter-clockwise seen from above; hand yaw =
// J1 + J2 + J3; the TCP lies `hand` mm along the hand from the J3 axis; z is the Z axis's
// position (0 without a Z axis). A robot without a wrist axis has J3 = 0.

import type { RobotInfo } from '../protocol/bus';

/** 0-based indices into `SimSample.positions` of the axes the drawing uses (null: absent). */
export interface ArmAxes {
  shoulder: number | null;
  elbow: number | null;
  wrist: number | null;
  z: number | null;
}

/** Joint values of the drawn arm [deg, deg, deg, mm]. */
export interface ArmPose {
  j1: number;
  j2: number;
  j3: number;
  z: number;
}

/** Find the axes by role (the first axis of each role); auxiliary axes are ignored. */
export function armAxes(robot: RobotInfo): ArmAxes {
  const find = (role: string): number | null => {
    for (let i = 0; i < robot.axes.length; i++) {
      const a = robot.axes[i];
      if (a && a.role === role) {
        return Number.isInteger(a.index) && a.index >= 1 ? a.index - 1 : i;
      }
    }
    return null;
  };
  return { shoulder: find('shoulder'), elbow: find('elbow'), wrist: find('wrist'), z: find('z') };
}

function at(values: readonly number[], i: number | null): number {
  if (i === null) return 0;
  const v = values[i];
  return v !== undefined && Number.isFinite(v) ? v : 0;
}

/** The arm's joints from axis positions in configuration order (absent or non-finite: 0). */
export function armPose(axes: ArmAxes, positions: readonly number[]): ArmPose {
  return {
    j1: at(positions, axes.shoulder),
    j2: at(positions, axes.elbow),
    j3: at(positions, axes.wrist),
    z: at(positions, axes.z),
  };
}

/** The home pose (each axis's `home`), drawn before the first sample arrives. */
export function homePositions(robot: RobotInfo): number[] {
  const n = robot.axes.reduce((m, a) => Math.max(m, a.index), robot.axes.length);
  const out = new Array<number>(n).fill(0);
  robot.axes.forEach((a, i) => {
    const k = Number.isInteger(a.index) && a.index >= 1 ? a.index - 1 : i;
    out[k] = a.home;
  });
  return out;
}

const RAD = Math.PI / 180;

/** Wrap an angle into (-180, 180] [deg]. */
export function wrap180(deg: number): number {
  const w = ((deg % 360) + 360) % 360;
  return w > 180 ? w - 360 : w;
}

/** Forward kinematics of the drawn arm: TCP x, y, z [mm] and yaw [deg]. */
export function forwardTcp(
  robot: Pick<RobotInfo, 'link1' | 'link2' | 'hand'>,
  p: ArmPose,
): { x: number; y: number; z: number; yaw: number } {
  const a1 = p.j1 * RAD;
  const a12 = (p.j1 + p.j2) * RAD;
  const yaw = p.j1 + p.j2 + p.j3;
  const ay = yaw * RAD;
  return {
    x: robot.link1 * Math.cos(a1) + robot.link2 * Math.cos(a12) + robot.hand * Math.cos(ay),
    y: robot.link1 * Math.sin(a1) + robot.link2 * Math.sin(a12) + robot.hand * Math.sin(ay),
    z: p.z,
    yaw: wrap180(yaw),
  };
}
