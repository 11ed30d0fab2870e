// Simulator panel (the paper's Fig. 5): a three.js view of the robot built from `ROBOT`
// (bus.robot / bus.onRobot) and animated from the simulator datagrams (bus.onSample), or, while
// the trace viewer has a trace open, the recorded robot at its scrubber (showRecorded).
//
// Scene units are millimetres in the robot's base frame, Z up (camera.up = +Z): the floor is
// the z = 0 plane, x/y as in the kinematics (crates/wrc-robot/src/kinematics.rs). Heights the
// controller gives (the TCP's z, a station's support height) are the Z axis's frame: the
// scene draws height z at `sceneZ(z)`, where the hand's wafer rests when the TCP is at z, so
// the hand meets the wafers in the stations where the controller says they are.
//
// A dual-blade robot (`RobotInfo.bladeB`) gets a second fork on the same wrist, its wafer
// plane `bladeB` mm above the hand's (below when negative), so that blade B too meets the
// stations at the heights the controller plans its transfers for.

import { injectStyle } from './dom';
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import type { Bus, RobotInfo, RobotState, SimSample } from './bus';
import type { WaferDisc } from './wafers';
import { StreamStats } from './stream';
import { armAxes, armPose, forwardTcp, homePositions, type ArmAxes, type ArmPose } from './sim-kinematics';

/** A station (cassette, aligner, process chamber) drawn as a box; all in the base frame. */
export interface StationSpec {
  /** Shown in the box's tooltip-less label list; also the default id. */
  name: string;
  /** Centre of the box's footprint [mm]. */
  x: number;
  y: number;
  /**
   * Bottom of the box [mm] in the Z axis's frame, like a station's support height (default 0);
   * drawn at `sceneZ(z)` on a stand that reaches down to the floor.
   */
  z?: number;
  /** Rotation about +Z [deg], counter-clockwise (default 0). */
  yaw?: number;
  /** Size along the box's own x (depth, towards the robot when yaw points at it), y, z [mm]. */
  depth: number;
  width: number;
  height: number;
  /** CSS colour (default a muted teal). */
  color?: string;
}

/** A recorded pose to draw instead of the live robot (the trace viewer at its scrubber). */
export interface RecordedFrame {
  /** The robot recorded; the drawing is rebuilt only when this object changes. */
  robot: RobotInfo;
  /** Axis positions [deg | mm], in `robot.axes` order. */
  positions: number[];
  /** The state the arm is tinted with (null: untinted). */
  state: RobotState | null;
  /** What the overlay says: which trace, where in it. */
  label: string;
}

export interface SimulatorHandle {
  /** Call when the panel is shown or its size changed. */
  resize(): void;
  /** Add a station box; returns its id (the name, made unique). */
  addStation(spec: StationSpec): string;
  removeStation(id: string): void;
  clearStations(): void;
  /** Show or hide the wafer on the hand (shown by default). */
  setWafer(onHand: boolean): void;
  /** Show or hide the wafer on blade B of a dual-blade robot (hidden by default; no-op without one). */
  setBladeBWafer(onBladeB: boolean): void;
  /**
   * The wafers in the stations (replacing those drawn before); call when the map or the
   * stations change, not per frame.
   */
  setStationWafers(discs: readonly WaferDisc[]): void;
  /**
   * Draw a recorded robot and pose instead of the live one, until called with null: then the
   * live robot and its latest datagram again. Live datagrams keep being counted meanwhile.
   */
  showRecorded(frame: RecordedFrame | null): void;
  /**
   * The joint values the 3D view draws now [deg, deg, deg, mm], read back from the scene
   * (for tests and the console); null before a robot is known or without WebGL.
   */
  drawnPose(): ArmPose | null;
  /** Remove the view and stop everything (not needed by the app; for tests and reuse). */
  dispose(): void;
}

// Drawing dimensions [mm] that the configuration does not give.
const BASE_H = 250; // top of the base housing above the floor
const BASE_R = 125;
const COLUMN_R = 72;
const SHOULDER_Z = 20; // shoulder (link 1 bottom) above the top of the base at z = 0
const LINK1_T = 34;
const LINK2_T = 28;
const LINK1_R = 44;
const LINK2_R = 38;
const HUB_T = 18;
const FORK_T = 7;
const ELBOW_DZ = LINK1_T + 2; // link 2's bottom above link 1's
const WRIST_DZ = LINK2_T + 2; // the wrist hub's bottom above link 2's
const WAFER_R = 150;
const WAFER_T = 2;
/** Scene height of the fork's top (where the hand's wafer rests) with the Z axis at 0 [mm]. */
const FORK_TOP_Z0 = BASE_H + SHOULDER_Z + ELBOW_DZ + WRIST_DZ + HUB_T + FORK_T;
/** Wafers float this much above what they rest on, against z-fighting [mm]. */
const WAFER_GAP = 0.5;
/** A double wafer (two wafers in one slot) is drawn this many wafers thick. */
const DOUBLE_SCALE = 3;
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

const STYLE_ID = 'sim-style';
const STYLE = `
.sim-root { position: relative; width: 100%; height: 100%; min-height: 0; overflow: hidden;
  background: #14171b; font: 12px/1.35 ui-monospace, SFMono-Regular, Menlo, Consolas, monospace; color: #c8d0d8; }
.sim-root canvas { position: absolute; inset: 0; display: block; width: 100%; height: 100%; outline: none; }
.sim-overlay { position: absolute; top: 8px; left: 8px; padding: 6px 9px; background: rgba(12,14,17,0.78);
  border: 1px solid #2c333b; border-radius: 4px; pointer-events: none; white-space: pre; min-width: 190px; }
.sim-overlay .sim-k { color: #7d8894; }
.sim-state { font-weight: 700; letter-spacing: 0.04em; }
.sim-state-IDLE { color: #9fb3c8; } .sim-state-MOVING { color: #5fd07a; } .sim-state-STOPPING { color: #f0b23c; }
.sim-state-HELD { color: #6cb8ff; } .sim-state-ERROR { color: #ff5a4e; } .sim-state-ESTOP { color: #ff3b30; }
.sim-warn { color: #f0b23c; }
.sim-buttons { position: absolute; right: 8px; bottom: 8px; display: flex; gap: 6px; }
.sim-buttons button { background: #232930; color: #c8d0d8; border: 1px solid #3a434d; border-radius: 3px;
  padding: 3px 8px; font: inherit; cursor: pointer; }
.sim-buttons button:hover { background: #2d353e; }
.sim-msg { position: absolute; inset: 0; display: flex; align-items: center; justify-content: center;
  text-align: center; padding: 24px; color: #c8d0d8; font-size: 14px; pointer-events: none; }
.sim-msg-box { background: rgba(12,14,17,0.85); border: 1px solid #3a434d; border-radius: 4px; padding: 12px 18px; max-width: 32em; }
.sim-msg-error .sim-msg-box { border-color: #a33; color: #ffb4ae; }
`;

/** True when the browser can give three.js a WebGL 2 context. */
export function webglAvailable(): boolean {
  try {
    const c = document.createElement('canvas');
    const gl = c.getContext('webgl2');
    // Give the probe's context back at once: browsers allow only a few at a time.
    gl?.getExtension('WEBGL_lose_context')?.loseContext();
    return gl !== null;
  } catch {
    return false;
  }
}

function div(cls: string, parent?: HTMLElement, text?: string): HTMLDivElement {
  const d = document.createElement('div');
  d.className = cls;
  if (text !== undefined) d.textContent = text;
  parent?.appendChild(d);
  return d;
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
function zCylinder(r: number, h: number, segments = 40): THREE.CylinderGeometry {
  const g = new THREE.CylinderGeometry(r, r, h, segments);
  g.rotateX(Math.PI / 2);
  g.translate(0, 0, h / 2);
  return g;
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

interface Tint {
  color: THREE.Color;
  amount: number;
  emissive: THREE.Color;
}

const TINTS: Record<RobotState, Tint> = {
  IDLE: { color: new THREE.Color('#ffffff'), amount: 0, emissive: new THREE.Color('#000000') },
  MOVING: { color: new THREE.Color('#ffffff'), amount: 0, emissive: new THREE.Color('#000000') },
  STOPPING: { color: new THREE.Color('#f0a020'), amount: 0.35, emissive: new THREE.Color('#1a1000') },
  // Held on its path: blue, apart from STOPPING's amber, so a kept motion reads as paused.
  HELD: { color: new THREE.Color('#4a9ae8'), amount: 0.35, emissive: new THREE.Color('#0a1420') },
  ERROR: { color: new THREE.Color('#ff3020'), amount: 0.55, emissive: new THREE.Color('#300600') },
  ESTOP: { color: new THREE.Color('#ff2010'), amount: 0.7, emissive: new THREE.Color('#4a0800') },
};

const JOINT_COLOR: Record<RobotState, string> = {
  IDLE: '#2a2f35',
  MOVING: '#2fa84f',
  STOPPING: '#c88a1a',
  HELD: '#3f8fd8',
  ERROR: '#b8281e',
  ESTOP: '#d01e14',
};

/** Materials whose colour follows the state, with their normal colour. */
class TintedMaterial {
  readonly base: THREE.Color;
  constructor(readonly mat: THREE.MeshStandardMaterial) {
    this.base = mat.color.clone();
  }
  apply(t: Tint): void {
    this.mat.color.copy(this.base).lerp(t.color, t.amount);
    this.mat.emissive.copy(t.emissive);
  }
}

/** The drawn robot: groups to pose and the materials to tint. */
interface RobotModel {
  root: THREE.Group;
  column: THREE.Mesh;
  lift: THREE.Group;
  shoulder: THREE.Group;
  elbow: THREE.Group;
  wrist: THREE.Group;
  wafer: THREE.Mesh;
  /** The wafer on blade B; null on a single-hand robot. */
  waferB: THREE.Mesh | null;
  /** Top of the base housing above the floor (lower than BASE_H for a blade below the hand). */
  baseH: number;
  axes: ArmAxes;
  robot: RobotInfo;
  reach: number;
  dispose(): void;
}

export function mountSimulator(el: HTMLElement, bus: Bus): SimulatorHandle {
  injectStyle(STYLE_ID, STYLE);
  const root = div('sim-root', el);
  const msg = div('sim-msg', root);
  const msgBox = div('sim-msg-box', msg);
  const showMessage = (text: string | null, error = false): void => {
    msg.style.display = text === null ? 'none' : '';
    msg.classList.toggle('sim-msg-error', error);
    msgBox.textContent = text ?? '';
  };

  const noop: SimulatorHandle = {
    resize() {},
    addStation: (spec) => spec.name,
    removeStation() {},
    clearStations() {},
    setWafer() {},
    setBladeBWafer() {},
    setStationWafers() {},
    showRecorded() {},
    drawnPose: () => null,
    dispose() {
      root.remove();
    },
  };

  if (!webglAvailable()) {
    showMessage(
      '3D simulator unavailable: this browser has no WebGL 2 (it may be disabled, or no GPU ' +
        'driver is available). Control, Editor and Plots keep working.',
      true,
    );
    return noop;
  }
  let renderer: THREE.WebGLRenderer;
  try {
    renderer = new THREE.WebGLRenderer({ antialias: true });
  } catch (e) {
    showMessage(`3D simulator unavailable: WebGL could not be started (${String(e)}).`, true);
    return noop;
  }
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.shadowMap.enabled = true;
  renderer.shadowMap.type = THREE.PCFShadowMap;
  renderer.setClearColor('#14171b');
  root.insertBefore(renderer.domElement, msg);
  renderer.domElement.tabIndex = 0;

  // Overlay and buttons.
  const overlay = div('sim-overlay', root);
  const buttons = div('sim-buttons', root);
  const button = (label: string, title: string, fn: () => void): void => {
    const b = document.createElement('button');
    b.type = 'button';
    b.textContent = label;
    b.title = title;
    b.addEventListener('click', fn);
    buttons.appendChild(b);
  };

  // Scene.
  const scene = new THREE.Scene();
  scene.background = new THREE.Color('#14171b');
  const camera = new THREE.PerspectiveCamera(40, 1, 5, 50000);
  camera.up.set(0, 0, 1);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.enableDamping = true;
  controls.dampingFactor = 0.12;
  controls.maxPolarAngle = Math.PI * 0.495;
  controls.minDistance = 100;
  controls.maxDistance = 20000;

  const hemi = new THREE.HemisphereLight('#dfe7f2', '#1a1d22', 1.4);
  hemi.position.set(0, 0, 1);
  scene.add(hemi);
  const sun = new THREE.DirectionalLight('#ffffff', 2.2);
  sun.position.set(700, -500, 1600);
  sun.castShadow = true;
  sun.shadow.mapSize.set(2048, 2048);
  sun.shadow.bias = -0.0005;
  scene.add(sun);
  scene.add(sun.target);

  const floorGroup = new THREE.Group();
  scene.add(floorGroup);
  const stationGroup = new THREE.Group();
  scene.add(stationGroup);
  const slotWaferGroup = new THREE.Group();
  scene.add(slotWaferGroup);

  let model: RobotModel | null = null;
  let waferOnHand = true;
  let waferOnBladeB = false;
  let latest: SimSample | null = null;
  let applied: SimSample | null = null;
  /** While set, the view draws this instead of the live datagrams. */
  let recorded: RecordedFrame | null = null;
  let state: RobotState = 'IDLE';
  let dirty = true;
  let disposed = false;
  let connected = bus.connected();
  const stats = new StreamStats();

  const linkMat = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#c3c9d1', metalness: 0.15, roughness: 0.5 }),
  );
  const baseMat = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#3b4149', metalness: 0.1, roughness: 0.7 }),
  );
  const columnMat = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#9aa1a9', metalness: 0.25, roughness: 0.35 }),
  );
  const handMat = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#e4e0d6', metalness: 0.05, roughness: 0.6 }),
  );
  const jointMat = new THREE.MeshStandardMaterial({ color: JOINT_COLOR.IDLE, metalness: 0.3, roughness: 0.5 });
  const waferMat = new THREE.MeshStandardMaterial({
    color: '#8597c4',
    metalness: 0.6,
    roughness: 0.2,
    transparent: true,
    opacity: 0.5,
    depthWrite: false,
    side: THREE.DoubleSide,
  });
  const trimMat = new THREE.MeshStandardMaterial({ color: '#e0a526', metalness: 0.1, roughness: 0.6 });
  // Faulty slots: a double wafer red, a cross-slotted one orange (as in the Wafers panel).
  const doubleMat = new THREE.MeshStandardMaterial({ color: '#e0352b', metalness: 0.3, roughness: 0.4, emissive: '#3a0500' });
  const crossMat = new THREE.MeshStandardMaterial({ color: '#f08a1c', metalness: 0.3, roughness: 0.4, emissive: '#2e1600' });
  // One wafer geometry for the hand and every slot (not disposed with a robot model).
  const waferGeo = zCylinder(WAFER_R, WAFER_T, 96);
  // The base housing keeps its colour: the moving parts show the state.
  const tinted = [linkMat, columnMat, handMat];

  const mesh = (g: THREE.BufferGeometry, m: THREE.Material, parent: THREE.Object3D): THREE.Mesh => {
    const x = new THREE.Mesh(g, m);
    x.castShadow = true;
    x.receiveShadow = true;
    parent.add(x);
    return x;
  };

  function buildFloor(reach: number): void {
    for (const c of [...floorGroup.children]) {
      floorGroup.remove(c);
      disposeObject(c);
    }
    const size = Math.max(1000, Math.ceil((2.6 * reach) / 500) * 500);
    const floor = new THREE.Mesh(
      new THREE.PlaneGeometry(size * 1.4, size * 1.4),
      new THREE.MeshStandardMaterial({ color: '#1b1f24', metalness: 0, roughness: 0.95 }),
    );
    floor.receiveShadow = true;
    floorGroup.add(floor);
    const fine = new THREE.GridHelper(size, size / 50, '#2a3038', '#252a31');
    fine.rotateX(Math.PI / 2);
    fine.position.z = 0.4;
    floorGroup.add(fine);
    const coarse = new THREE.GridHelper(size, size / 500, '#4a5562', '#38414b');
    coarse.rotateX(Math.PI / 2);
    coarse.position.z = 0.6;
    floorGroup.add(coarse);
    const axesHelper = new THREE.AxesHelper(Math.min(250, reach * 0.4));
    axesHelper.position.z = 1;
    floorGroup.add(axesHelper);
    const s = sun.shadow.camera;
    s.left = -size / 2;
    s.right = size / 2;
    s.top = size / 2;
    s.bottom = -size / 2;
    s.near = 10;
    s.far = 6000;
    s.updateProjectionMatrix();
  }

  function buildRobot(robot: RobotInfo): RobotModel {
    const l1 = Math.max(0, robot.link1 || 0);
    const l2 = Math.max(0, robot.link2 || 0);
    const hand = Number.isFinite(robot.hand) ? robot.hand : 0;
    const axes = armAxes(robot);
    const stack = bladeStack(hand, robot.bladeB);
    const baseH = BASE_H - stack.drop;
    const group = new THREE.Group();
    const geoms: THREE.BufferGeometry[] = [];
    const g = <T extends THREE.BufferGeometry>(x: T): T => {
      geoms.push(x);
      return x;
    };

    // Base housing and Z column (the column is scaled to reach the shoulder).
    mesh(g(zCylinder(BASE_R, baseH, 48)), baseMat.mat, group);
    const ring = mesh(g(zCylinder(BASE_R + 4, 8, 48)), trimMat, group);
    ring.position.z = baseH - 14;
    const column = mesh(g(zCylinder(COLUMN_R, 1, 40)), columnMat.mat, group);
    column.position.z = baseH - 2;

    const lift = new THREE.Group();
    lift.position.z = baseH + SHOULDER_Z;
    group.add(lift);
    const shoulder = new THREE.Group();
    lift.add(shoulder);
    mesh(g(slot(l1, LINK1_R, LINK1_T)), linkMat.mat, shoulder);
    const cap1 = mesh(g(zCylinder(LINK1_R * 0.55, 4)), jointMat, shoulder);
    cap1.position.z = LINK1_T;

    const elbow = new THREE.Group();
    elbow.position.set(l1, 0, ELBOW_DZ);
    shoulder.add(elbow);
    mesh(g(slot(l2, LINK2_R, LINK2_T)), linkMat.mat, elbow);
    const cap2 = mesh(g(zCylinder(LINK2_R * 0.55, 4)), jointMat, elbow);
    cap2.position.z = LINK2_T;

    const wrist = new THREE.Group();
    wrist.position.set(l2, 0, WRIST_DZ);
    elbow.add(wrist);
    mesh(g(zCylinder(30, HUB_T)), jointMat, wrist);
    // Bars from the wrist hub to the palm (behind the wrist when hand < 125 mm) and, on a
    // dual-blade robot, to the post that carries the upper fork.
    for (const b of stack.bars) {
      const bar = mesh(g(slot(Math.abs(b.x1 - b.x0), BAR_R, FORK_T)), handMat.mat, wrist);
      bar.position.set(Math.min(b.x0, b.x1), 0, b.z);
    }
    if (stack.post) {
      const post = mesh(g(zCylinder(POST_R, stack.post.z1 - stack.post.z0, 24)), handMat.mat, wrist);
      post.position.set(stack.post.x, 0, stack.post.z0);
    }
    const forkGeo = g(forkGeometry(hand));
    const bladeWafer = (forkZ: number, visible: boolean): THREE.Mesh => {
      const fork = mesh(forkGeo, handMat.mat, wrist);
      fork.position.z = forkZ;
      const w = mesh(waferGeo, waferMat, wrist);
      w.position.set(hand, 0, forkZ + FORK_T + WAFER_GAP);
      w.castShadow = false;
      w.visible = visible;
      w.renderOrder = 1;
      return w;
    };
    const wafer = bladeWafer(stack.forkA, waferOnHand);
    const waferB = stack.forkB === null ? null : bladeWafer(stack.forkB, waferOnBladeB);

    const reach = l1 + l2 + Math.abs(hand) + WAFER_R;
    return {
      root: group,
      column,
      lift,
      shoulder,
      elbow,
      wrist,
      wafer,
      waferB,
      baseH,
      axes,
      robot,
      reach,
      dispose() {
        for (const x of geoms) x.dispose();
      },
    };
  }

  function pose(p: ArmPose): void {
    if (!model) return;
    const d = THREE.MathUtils.DEG2RAD;
    model.lift.position.z = model.baseH + SHOULDER_Z + p.z;
    model.column.scale.z = Math.max(1, SHOULDER_Z + 2 + p.z);
    model.shoulder.rotation.z = p.j1 * d;
    model.elbow.rotation.z = p.j2 * d;
    model.wrist.rotation.z = p.j3 * d;
  }

  function applyState(s: RobotState): void {
    state = s;
    const t = TINTS[s];
    for (const m of tinted) m.apply(t);
    jointMat.color.set(JOINT_COLOR[s]);
  }

  function fitCamera(reach: number, top = false): void {
    const r = Math.max(500, reach);
    const target = new THREE.Vector3(0, 0, BASE_H * 0.8);
    if (top) camera.position.set(0, -r * 0.02, BASE_H + r * 3.4);
    else camera.position.set(r * 1.8, -r * 2.2, BASE_H + r * 1.5);
    controls.target.copy(target);
    camera.near = Math.max(1, r / 100);
    camera.far = r * 60;
    camera.updateProjectionMatrix();
    controls.update();
    dirty = true;
  }

  function setRobot(robot: RobotInfo): void {
    const first = model === null;
    if (model) {
      scene.remove(model.root);
      model.dispose();
    }
    model = buildRobot(robot);
    scene.add(model.root);
    buildFloor(model.reach);
    pose(armPose(model.axes, applied?.positions ?? latest?.positions ?? homePositions(robot)));
    if (first) fitCamera(model.reach);
    dirty = true;
    updateOverlay(performance.now());
  }

  button('Top', 'View from above', () => fitCamera(model?.reach ?? 600, true));
  button('Reset view', 'Back to the default camera', () => fitCamera(model?.reach ?? 600));
  button('Reset counts', 'Reset the lost-datagram counters', () => {
    stats.reset();
    updateOverlay(performance.now());
  });

  // Overlay text.
  function line(parent: HTMLElement, key: string, value: string, cls = ''): void {
    const l = document.createElement('div');
    const k = document.createElement('span');
    k.className = 'sim-k';
    k.textContent = key.padEnd(8);
    const v = document.createElement('span');
    v.textContent = value;
    if (cls) v.className = cls;
    l.append(k, v);
    parent.appendChild(l);
  }
  const fmt = (x: number, d = 1): string => (Number.isFinite(x) ? x.toFixed(d) : '—');
  function updateOverlay(now: number): void {
    overlay.replaceChildren();
    const r = model?.robot ?? bus.robot();
    line(overlay, 'robot', r ? r.name : '—');
    if (!connected) line(overlay, 'link', 'disconnected', 'sim-warn');
    const s = recorded === null ? applied : null;
    const rate = stats.rate(now);
    if (recorded !== null) {
      line(overlay, 'trace', recorded.label, 'sim-warn');
      const st = recorded.state;
      line(overlay, 'state', st ?? '—', st ? `sim-state sim-state-${st}` : '');
      if (model) {
        const tcp = forwardTcp(model.robot, armPose(model.axes, recorded.positions));
        line(overlay, 'TCP', `${fmt(tcp.x)} ${fmt(tcp.y)} ${fmt(tcp.z)} mm`);
        line(overlay, 'yaw', `${fmt(tcp.yaw, 2)}°`);
      }
    } else if (s) {
      line(overlay, 'state', s.state, `sim-state sim-state-${s.state}`);
      line(overlay, 'homed', s.homed ? 'yes' : 'no', s.homed ? '' : 'sim-warn');
      line(overlay, 'TCP', `${fmt(s.x)} ${fmt(s.y)} ${fmt(s.z)} mm`);
      line(overlay, 'yaw', `${fmt(s.yaw, 2)}°`);
      line(overlay, 'seq', String(s.seq));
    } else {
      line(overlay, 'state', '—');
    }
    line(overlay, 'rate', rate > 0 ? `${rate.toFixed(0)} Hz` : 'no stream', rate > 0 ? '' : 'sim-warn');
    line(
      overlay,
      'lost',
      `${stats.lost} in ${stats.gaps} gap${stats.gaps === 1 ? '' : 's'}`,
      stats.lost > 0 ? 'sim-warn' : '',
    );
    if (s && model) {
      // The drawing follows ROBOT's geometry; say so when it disagrees with the stream's TCP.
      const tcp = forwardTcp(model.robot, armPose(model.axes, s.positions));
      const err = Math.hypot(tcp.x - s.x, tcp.y - s.y, tcp.z - s.z);
      if (err > 1) line(overlay, 'geometry', `off by ${err.toFixed(1)} mm`, 'sim-warn');
    }
    if (!model) showMessage(connected ? 'Waiting for the robot description (ROBOT)…' : 'Not connected to the controller.');
    else showMessage(null);
  }

  // Bus.
  const unsubs = [
    // A recorded frame keeps its own robot; the live one is drawn again when it ends.
    bus.onRobot((r) => {
      if (recorded === null) setRobot(r);
    }),
    bus.onSample((s) => {
      latest = s;
      stats.push(s, performance.now());
    }),
    bus.onConnection((c) => {
      connected = c;
      updateOverlay(performance.now());
    }),
  ];
  const r0 = bus.robot();
  if (r0) setRobot(r0);
  else {
    buildFloor(600);
    fitCamera(600);
  }
  applyState(state);

  // Size.
  let width = 0;
  let height = 0;
  function resize(): void {
    if (disposed) return;
    const w = root.clientWidth;
    const h = root.clientHeight;
    if (w <= 0 || h <= 0) return;
    if (w === width && h === height) return;
    width = w;
    height = h;
    renderer.setSize(w, h, false);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    dirty = true;
  }
  const ro = typeof ResizeObserver !== 'undefined' ? new ResizeObserver(() => resize()) : null;
  ro?.observe(root);
  controls.addEventListener('change', () => {
    dirty = true;
  });

  let contextLost = false;
  renderer.domElement.addEventListener('webglcontextlost', (e) => {
    e.preventDefault();
    contextLost = true;
    showMessage('3D view lost its WebGL context; it resumes when the browser restores it.', true);
  });
  renderer.domElement.addEventListener('webglcontextrestored', () => {
    contextLost = false;
    dirty = true;
    showMessage(null);
  });

  // Animation: the latest sample is applied once per frame, not per datagram.
  let lastOverlay = 0;
  let raf = 0;
  function frame(now: number): void {
    if (disposed) return;
    raf = requestAnimationFrame(frame);
    const visible = el.isConnected && root.offsetParent !== null;
    if (!visible) return;
    if (width === 0) resize();
    if (recorded === null && latest !== applied && latest !== null) {
      applied = latest;
      if (model) pose(armPose(model.axes, applied.positions));
      if (applied.state !== state) applyState(applied.state);
      dirty = true;
    }
    if (controls.update()) dirty = true;
    if (now - lastOverlay > 250) {
      lastOverlay = now;
      updateOverlay(now);
    }
    if (dirty && width > 0 && !contextLost) {
      dirty = false;
      renderer.render(scene, camera);
    }
  }
  raf = requestAnimationFrame(frame);

  // Stations.
  const stations = new Map<string, THREE.Object3D>();
  function addStation(spec: StationSpec): string {
    let id = spec.name || 'station';
    for (let k = 2; stations.has(id); k++) id = `${spec.name}#${k}`;
    const grp = new THREE.Group();
    const geo = new THREE.BoxGeometry(Math.max(1, spec.depth), Math.max(1, spec.width), Math.max(1, spec.height));
    const color = new THREE.Color(spec.color ?? '#3f8f8a');
    const box = new THREE.Mesh(
      geo,
      new THREE.MeshStandardMaterial({ color, transparent: true, opacity: 0.28, depthWrite: false, roughness: 0.8 }),
    );
    box.receiveShadow = true;
    const edges = new THREE.LineSegments(
      new THREE.EdgesGeometry(geo),
      new THREE.LineBasicMaterial({ color: color.clone().offsetHSL(0, 0, 0.2) }),
    );
    grp.add(box, edges);
    const bottom = sceneZ(spec.z ?? 0);
    grp.position.set(spec.x, spec.y, bottom + Math.max(1, spec.height) / 2);
    grp.rotation.z = THREE.MathUtils.degToRad(spec.yaw ?? 0);
    if (bottom > 1) {
      // A stand down to the floor, so the box does not float.
      const stand = new THREE.Mesh(
        new THREE.BoxGeometry(Math.max(1, spec.depth * 0.5), Math.max(1, spec.width * 0.5), bottom),
        new THREE.MeshStandardMaterial({ color, transparent: true, opacity: 0.14, depthWrite: false, roughness: 0.9 }),
      );
      stand.position.z = -Math.max(1, spec.height) / 2 - bottom / 2;
      grp.add(stand);
    }
    grp.name = id;
    stationGroup.add(grp);
    stations.set(id, grp);
    dirty = true;
    return id;
  }
  function removeStation(id: string): void {
    const o = stations.get(id);
    if (!o) return;
    stationGroup.remove(o);
    disposeObject(o);
    stations.delete(id);
    dirty = true;
  }

  // Wafers in the stations: a pool of meshes sharing one geometry, placed when the map
  // changes (meshes are only added when the pool is too small).
  const slotWafers: THREE.Mesh[] = [];
  function setStationWafers(discs: readonly WaferDisc[]): void {
    while (slotWafers.length < discs.length) {
      const m = new THREE.Mesh(waferGeo, waferMat);
      m.castShadow = false;
      m.receiveShadow = true;
      m.renderOrder = 1;
      slotWaferGroup.add(m);
      slotWafers.push(m);
    }
    slotWafers.forEach((m, i) => {
      const d = discs[i];
      m.visible = d !== undefined;
      if (!d) return;
      m.material = d.state === 'double' ? doubleMat : d.state === 'cross' ? crossMat : waferMat;
      m.position.set(d.x, d.y, sceneZ(d.z) + WAFER_GAP);
      // Yaw about +Z, then a cross-slotted wafer's tilt about the station's hand direction.
      m.rotation.set(THREE.MathUtils.degToRad(d.tilt), 0, THREE.MathUtils.degToRad(d.yaw), 'ZYX');
      m.scale.set(1, 1, d.state === 'double' ? DOUBLE_SCALE : 1);
      m.name = `${d.station}.${d.slot}`;
    });
    dirty = true;
  }

  function showRecorded(frame: RecordedFrame | null): void {
    recorded = frame;
    if (frame !== null) {
      if (model?.robot !== frame.robot) setRobot(frame.robot);
      if (model) pose(armPose(model.axes, frame.positions));
      applyState(frame.state ?? 'IDLE');
    } else {
      const live = bus.robot();
      if (live && model?.robot !== live) setRobot(live);
      // The next frame applies the latest datagram again.
      applied = null;
      if (model) pose(armPose(model.axes, latest?.positions ?? homePositions(model.robot)));
      applyState(latest?.state ?? 'IDLE');
    }
    dirty = true;
    updateOverlay(performance.now());
  }

  function drawnPose(): ArmPose | null {
    if (!model) return null;
    const deg = THREE.MathUtils.RAD2DEG;
    return {
      j1: model.shoulder.rotation.z * deg,
      j2: model.elbow.rotation.z * deg,
      j3: model.wrist.rotation.z * deg,
      z: model.lift.position.z - model.baseH - SHOULDER_Z,
    };
  }

  resize();
  updateOverlay(performance.now());

  return {
    resize() {
      width = 0; // force: the container may have been hidden at the same size
      resize();
      dirty = true;
    },
    addStation,
    removeStation,
    clearStations() {
      for (const id of [...stations.keys()]) removeStation(id);
    },
    setWafer(onHand: boolean) {
      if (onHand === waferOnHand) return;
      waferOnHand = onHand;
      if (model) model.wafer.visible = onHand;
      dirty = true;
    },
    setBladeBWafer(onBladeB: boolean) {
      if (onBladeB === waferOnBladeB) return;
      waferOnBladeB = onBladeB;
      if (model?.waferB) model.waferB.visible = onBladeB;
      dirty = true;
    },
    setStationWafers,
    showRecorded,
    drawnPose,
    dispose() {
      if (disposed) return;
      disposed = true;
      cancelAnimationFrame(raf);
      for (const u of unsubs) u();
      ro?.disconnect();
      controls.dispose();
      model?.dispose();
      disposeObject(scene);
      renderer.dispose();
      root.remove();
    },
  };
}

function disposeObject(o: THREE.Object3D): void {
  o.traverse((x) => {
    const m = x as THREE.Mesh;
    if (m.geometry) m.geometry.dispose();
    const mat = (m as { material?: THREE.Material | THREE.Material[] }).material;
    if (Array.isArray(mat)) mat.forEach((q) => q.dispose());
    else mat?.dispose();
  });
}
