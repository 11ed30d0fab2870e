// The drawn robot: a base housing with a Z column, two links and a wrist carrying the fork of
// the hand (and, on a dual-blade robot, blade B's fork), built with three.js from `ROBOT` and
// posed from joint values. Also the drawing's own dimensions and `sceneZ`, which puts the
// controller's heights into the scene.
//
// Scene units are millimetres in the robot's base frame, Z up: the floor is the z = 0 plane,
// x/y as in the kinematics (crates/wrc-robot/src/kinematics.rs). Heights the controller gives
// (the TCP's z, a station's support height) are the Z axis's frame: the scene draws height z
// at `sceneZ(z)`, where the hand's wafer rests when the TCP is at z, so the hand meets the
// wafers in the stations where the controller says they are.
//
// A dual-blade robot (`RobotInfo.bladeB`) gets a second fork on the same wrist, its wafer
// plane `bladeB` mm above the hand's (below when negative), so that blade B too meets the
// stations at the heights the controller plans its transfers for.

import * as THREE from 'three';
import type { RobotInfo } from '../protocol/bus';
import type { Materials } from './materials';
import { armAxes, type ArmAxes, type ArmPose } from './sim-kinematics';

// Drawing dimensions [mm] that the configuration does not give.
/** Top of the base housing above the floor [mm]. */
export const BASE_H = 250;
const BASE_R = 125;
const COLUMN_R = 72;
/** Shoulder (link 1 bottom) above the top of the base at z = 0 [mm]. */
const SHOULDER_Z = 20;
const LINK1_T = 34;
const LINK2_T = 28;
const LINK1_R = 44;
const LINK2_R = 38;
const HUB_T = 18;
const FORK_T = 7;
/** Link 2's bottom above link 1's [mm]. */
const ELBOW_DZ = LINK1_T + 2;
/** The wrist hub's bottom above link 2's [mm]. */
const WRIST_DZ = LINK2_T + 2;
export const WAFER_R = 150;
export const WAFER_T = 2;
/** Scene height of the fork's top (where the hand's wafer rests) with the Z axis at 0 [mm]. */
const FORK_TOP_Z0 = BASE_H + SHOULDER_Z + ELBOW_DZ + WRIST_DZ + HUB_T + FORK_T;
/** Wafers float this much above what they rest on, against z-fighting [mm]. */
export const WAFER_GAP = 0.5;
/** Back of the fork's palm behind the TCP [mm]. */
const PALM_BACK = 125;
const BAR_R = 22;
/** The post that joins a dual-blade robot's two forks, behind their wafers [mm]. */
const POST_R = 14;
const POST_CLEARANCE = 6;
/** The base housing is drawn at least this tall however far blade B hangs below the hand [mm]. */
const MIN_BASE_H = 60;

/** The scene height of a height `z` of the Z axis's frame (a TCP z, a support height) [mm]. */
export function sceneZ(z: number): number {
  return FORK_TOP_Z0 + z;
}

/** A bar of the hand in the wrist frame: from x0 to x1 along the hand, its bottom at z [mm]. */
export interface HandBar {
  x0: number;
  x1: number;
  z: number;
}

/** Where the drawing puts the fork(s) of a hand in the wrist frame (x along the hand) [mm]. */
export interface BladeStack {
  /**
   * How much lower than usual the base housing (and so the whole arm) is drawn. A blade below
   * the hand would cut through link 2; instead the arm is drawn lower, blade B rests on the
   * wrist hub and the hand's fork as much higher on the post, so the hand's wafer stays at
   * `sceneZ` and blade B's clears the links.
   */
  drop: number;
  /** Bottom of the hand's (blade A's) fork. */
  forkA: number;
  /** Bottom of blade B's fork; null on a single-hand robot. */
  forkB: number | null;
  /** The bars: the lower fork's from the wrist hub, and the upper fork's to the post. */
  bars: HandBar[];
  /**
   * The post from the lower fork's bar up to the upper fork's, behind both wafers (a post at
   * the wrist would pierce the lower wafer when the TCP is near the wrist); null on a single
   * hand.
   */
  post: { x: number; z0: number; z1: number } | null;
}

/**
 * The layout of the hand: one fork on the wrist hub, as the view always drew it, or, with
 * `bladeB` (a dual-blade robot), two forks `bladeB` mm apart joined behind their wafers.
 */
export function bladeStack(hand: number, bladeB: number | null | undefined): BladeStack {
  const palmBack = hand - PALM_BACK;
  if (bladeB === null || bladeB === undefined || !Number.isFinite(bladeB)) {
    return { drop: 0, forkA: HUB_T, forkB: null, bars: [{ x0: 0, x1: palmBack, z: HUB_T }], post: null };
  }
  const drop = Math.min(Math.max(0, -bladeB), BASE_H - MIN_BASE_H);
  const forkA = HUB_T + drop;
  const forkB = forkA + bladeB;
  const lower = Math.min(forkA, forkB);
  const upper = Math.max(forkA, forkB);
  const postX = hand - WAFER_R - POST_R - POST_CLEARANCE;
  return {
    drop,
    forkA,
    forkB,
    bars: [
      { x0: Math.min(0, palmBack, postX), x1: Math.max(0, palmBack, postX), z: lower },
      { x0: postX, x1: palmBack, z: upper },
    ],
    post: { x: postX, z0: lower, z1: upper + FORK_T },
  };
}

/** A stadium (rounded slot) from (0,0) to (len,0) with radius r, extruded `t` up from z = 0. */
function slot(len: number, r: number, t: number): THREE.ExtrudeGeometry {
  const s = new THREE.Shape();
  const L = Math.max(0, len);
  s.moveTo(0, -r);
  s.lineTo(L, -r);
  s.absarc(L, 0, r, -Math.PI / 2, Math.PI / 2, false);
  s.lineTo(0, r);
  s.absarc(0, 0, r, Math.PI / 2, (3 * Math.PI) / 2, false);
  return new THREE.ExtrudeGeometry(s, { depth: t, bevelEnabled: false, curveSegments: 24 });
}

/** A Z-axis cylinder of radius r from z = 0 to z = h. */
export function zCylinder(r: number, h: number, segments = 40): THREE.CylinderGeometry {
  const g = new THREE.CylinderGeometry(r, r, h, segments);
  g.rotateX(Math.PI / 2);
  g.translate(0, 0, h / 2);
  return g;
}

/** Which blades show a wafer, and whether it is uncertain (drawn apart, with a `?`). */
export interface BladeWafers {
  hand: boolean;
  bladeB: boolean;
  handUncertain?: boolean;
  bladeBUncertain?: boolean;
}

/** The fork of the hand, in the wrist frame, the TCP (wafer centre) at (tcp, 0). */
function forkGeometry(tcp: number): THREE.ExtrudeGeometry {
  const xb = tcp - PALM_BACK; // back of the palm
  const xf = tcp - 85; // front of the palm, root of the tines
  const xt = tcp + 128; // tine tips
  const inner = 40;
  const outer = 66;
  const s = new THREE.Shape();
  s.moveTo(xb, -outer);
  s.lineTo(xt - 8, -outer);
  s.quadraticCurveTo(xt, -outer, xt, -outer + 8);
  s.lineTo(xt, -inner - 4);
  s.quadraticCurveTo(xt, -inner, xt - 4, -inner);
  s.lineTo(xf, -inner);
  s.lineTo(xf, inner);
  s.lineTo(xt - 4, inner);
  s.quadraticCurveTo(xt, inner, xt, inner + 4);
  s.lineTo(xt, outer - 8);
  s.quadraticCurveTo(xt, outer, xt - 8, outer);
  s.lineTo(xb, outer);
  s.lineTo(xb, -outer);
  return new THREE.ExtrudeGeometry(s, { depth: FORK_T, bevelEnabled: false, curveSegments: 8 });
}

function mesh(g: THREE.BufferGeometry, m: THREE.Material, parent: THREE.Object3D): THREE.Mesh {
  const x = new THREE.Mesh(g, m);
  x.castShadow = true;
  x.receiveShadow = true;
  parent.add(x);
  return x;
}

/** The drawn robot: its groups, posed by `pose`, under `root`. */
export class RobotModel {
  readonly root = new THREE.Group();
  readonly robot: RobotInfo;
  /** The axes that drive the drawing. */
  readonly axes: ArmAxes;
  /** The arm's reach with a wafer on the hand [mm] (for the floor and the camera). */
  readonly reach: number;
  /** Top of the base housing above the floor (lower than BASE_H for a blade below the hand). */
  private readonly baseH: number;
  private readonly column: THREE.Mesh;
  private readonly lift: THREE.Group;
  private readonly shoulder: THREE.Group;
  private readonly elbow: THREE.Group;
  private readonly wrist: THREE.Group;
  private readonly wafer: THREE.Mesh;
  /** The wafer on blade B; null on a single-hand robot. */
  private readonly waferB: THREE.Mesh | null;
  /** The geometries made for this robot (the shared wafer geometry is not one of them). */
  private readonly geoms: THREE.BufferGeometry[] = [];

  /**
   * Build the drawing of `robot` with the view's materials; `waferGeo` is the wafer geometry
   * shared with the stations' wafers, `wafers` which blades show a wafer.
   */
  constructor(
    robot: RobotInfo,
    private readonly mats: Materials,
    waferGeo: THREE.BufferGeometry,
    wafers: BladeWafers,
  ) {
    const l1 = Math.max(0, robot.link1 || 0);
    const l2 = Math.max(0, robot.link2 || 0);
    const hand = Number.isFinite(robot.hand) ? robot.hand : 0;
    const stack = bladeStack(hand, robot.bladeB);
    const baseH = BASE_H - stack.drop;
    const group = this.root;
    const g = <T extends THREE.BufferGeometry>(x: T): T => {
      this.geoms.push(x);
      return x;
    };

    // Base housing and Z column (the column is scaled to reach the shoulder).
    mesh(g(zCylinder(BASE_R, baseH, 48)), mats.base.mat, group);
    const ring = mesh(g(zCylinder(BASE_R + 4, 8, 48)), mats.trim, group);
    ring.position.z = baseH - 14;
    const column = mesh(g(zCylinder(COLUMN_R, 1, 40)), mats.column.mat, group);
    column.position.z = baseH - 2;

    const lift = new THREE.Group();
    lift.position.z = baseH + SHOULDER_Z;
    group.add(lift);
    const shoulder = new THREE.Group();
    lift.add(shoulder);
    mesh(g(slot(l1, LINK1_R, LINK1_T)), mats.link.mat, shoulder);
    const cap1 = mesh(g(zCylinder(LINK1_R * 0.55, 4)), mats.joint, shoulder);
    cap1.position.z = LINK1_T;

    const elbow = new THREE.Group();
    elbow.position.set(l1, 0, ELBOW_DZ);
    shoulder.add(elbow);
    mesh(g(slot(l2, LINK2_R, LINK2_T)), mats.link.mat, elbow);
    const cap2 = mesh(g(zCylinder(LINK2_R * 0.55, 4)), mats.joint, elbow);
    cap2.position.z = LINK2_T;

    const wrist = new THREE.Group();
    wrist.position.set(l2, 0, WRIST_DZ);
    elbow.add(wrist);
    mesh(g(zCylinder(30, HUB_T)), mats.joint, wrist);
    // Bars from the wrist hub to the palm (behind the wrist when hand < 125 mm) and, on a
    // dual-blade robot, to the post that carries the upper fork.
    for (const b of stack.bars) {
      const bar = mesh(g(slot(Math.abs(b.x1 - b.x0), BAR_R, FORK_T)), mats.hand.mat, wrist);
      bar.position.set(Math.min(b.x0, b.x1), 0, b.z);
    }
    if (stack.post) {
      const post = mesh(g(zCylinder(POST_R, stack.post.z1 - stack.post.z0, 24)), mats.hand.mat, wrist);
      post.position.set(stack.post.x, 0, stack.post.z0);
    }
    const forkGeo = g(forkGeometry(hand));
    const bladeWafer = (forkZ: number, visible: boolean): THREE.Mesh => {
      const fork = mesh(forkGeo, mats.hand.mat, wrist);
      fork.position.z = forkZ;
      const w = mesh(waferGeo, mats.wafer, wrist);
      w.position.set(hand, 0, forkZ + FORK_T + WAFER_GAP);
      w.castShadow = false;
      w.visible = visible;
      w.renderOrder = 1;
      return w;
    };

    this.robot = robot;
    this.axes = armAxes(robot);
    this.reach = l1 + l2 + Math.abs(hand) + WAFER_R;
    this.baseH = baseH;
    this.column = column;
    this.lift = lift;
    this.shoulder = shoulder;
    this.elbow = elbow;
    this.wrist = wrist;
    this.wafer = bladeWafer(stack.forkA, wafers.hand);
    this.waferB = stack.forkB === null ? null : bladeWafer(stack.forkB, wafers.bladeB);
    this.showWafer(wafers.hand, wafers.handUncertain === true);
    this.showBladeBWafer(wafers.bladeB, wafers.bladeBUncertain === true);
  }

  /** Put the arm at joint values `p` [deg, deg, deg, mm]. */
  pose(p: ArmPose): void {
    const d = THREE.MathUtils.DEG2RAD;
    this.lift.position.z = this.baseH + SHOULDER_Z + p.z;
    this.column.scale.z = Math.max(1, SHOULDER_Z + 2 + p.z);
    this.shoulder.rotation.z = p.j1 * d;
    this.elbow.rotation.z = p.j2 * d;
    this.wrist.rotation.z = p.j3 * d;
  }

  /** The joint values drawn now, read back from the scene [deg, deg, deg, mm]. */
  drawnPose(): ArmPose {
    const deg = THREE.MathUtils.RAD2DEG;
    return {
      j1: this.shoulder.rotation.z * deg,
      j2: this.elbow.rotation.z * deg,
      j3: this.wrist.rotation.z * deg,
      z: this.lift.position.z - this.baseH - SHOULDER_Z,
    };
  }

  /** Show or hide the wafer on the hand (blade A); an uncertain one is drawn apart. */
  showWafer(on: boolean, uncertain = false): void {
    this.wafer.visible = on;
    this.wafer.material = uncertain ? this.mats.uncertain : this.mats.wafer;
  }

  /** Show or hide the wafer on blade B (no-op on a single-hand robot); an uncertain one is drawn apart. */
  showBladeBWafer(on: boolean, uncertain = false): void {
    if (!this.waferB) return;
    this.waferB.visible = on;
    this.waferB.material = uncertain ? this.mats.uncertain : this.mats.wafer;
  }

  /** How each blade's wafer is drawn now: `none`, `wafer` or `uncertain` (for tests and the console). */
  drawnBladeWafers(): { hand: string; bladeB: string | null } {
    const look = (m: THREE.Mesh): string => (!m.visible ? 'none' : m.material === this.mats.uncertain ? 'uncertain' : 'wafer');
    return { hand: look(this.wafer), bladeB: this.waferB ? look(this.waferB) : null };
  }

  /** Free the geometries made for this robot (the materials and the wafer geometry stay). */
  dispose(): void {
    for (const x of this.geoms) x.dispose();
  }
}
