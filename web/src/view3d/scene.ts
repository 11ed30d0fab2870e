// The 3D view's scene: renderer, camera and orbit controls, lights, the floor grid, the drawn
// robot, the stations as translucent boxes and the wafers in them. It renders only when
// something changed (`dirty`); what to draw comes from the simulator panel (simulator.ts).

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import type { RobotInfo } from '../protocol/bus';
import { Materials } from './materials';
import { BASE_H, RobotModel, WAFER_GAP, WAFER_R, WAFER_T, sceneZ, zCylinder, type BladeWafers } from './robot-model';

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

/** A wafer drawn in a station, in the robot's base frame. */
export interface WaferDisc {
  station: string;
  slot: number;
  /** Wafer centre [mm]. */
  x: number;
  y: number;
  /** Height of the wafer's underside [mm] (the slot's support height; half a pitch higher for a cross-slotted wafer). */
  z: number;
  /** The station's hand direction [deg]: a cross-slotted wafer is tilted about it. */
  yaw: number;
  /** `uncertain`: perhaps this wafer, perhaps nothing (after an interrupted transfer). */
  state: 'wafer' | 'double' | 'cross' | 'uncertain';
  wafer: string | null;
  /** Tilt about the `yaw` direction [deg] (0 but for a cross-slotted wafer). */
  tilt: number;
}

/** A double wafer (two wafers in one slot) is drawn this many wafers thick. */
const DOUBLE_SCALE = 3;

/** Dispose of the geometries and materials of `o` and everything below it. */
function disposeObject(o: THREE.Object3D): void {
  o.traverse((x) => {
    const m = x as THREE.Mesh;
    if (m.geometry) m.geometry.dispose();
    const mat = (m as { material?: THREE.Material | THREE.Material[] }).material;
    if (Array.isArray(mat)) mat.forEach((q) => q.dispose());
    else mat?.dispose();
  });
}

/** The three.js scene of the Simulator tab and what is drawn in it; renders into `renderer`. */
export class SimScene {
  readonly scene = new THREE.Scene();
  readonly camera = new THREE.PerspectiveCamera(40, 1, 5, 50000);
  readonly materials: Materials;
  /** The drawn robot (null before one is known). */
  robot: RobotModel | null = null;
  /** Something changed since the last render. */
  dirty = true;
  private readonly controls: OrbitControls;
  private readonly sun = new THREE.DirectionalLight('#ffffff', 2.2);
  private readonly floorGroup = new THREE.Group();
  private readonly stationGroup = new THREE.Group();
  private readonly slotWaferGroup = new THREE.Group();
  /** One wafer geometry for the hand and every slot (not disposed with a robot model). */
  private readonly waferGeo: THREE.CylinderGeometry;
  private readonly stations = new Map<string, THREE.Object3D>();
  /**
   * The wafers in the stations: a pool of meshes sharing one geometry, placed when the map
   * changes (meshes are only added when the pool is too small).
   */
  private readonly slotWafers: THREE.Mesh[] = [];
  /** The canvas size [CSS px]; 0 until known (or to be measured again). */
  private width = 0;
  private height = 0;

  constructor(private readonly renderer: THREE.WebGLRenderer) {
    renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    renderer.shadowMap.enabled = true;
    renderer.shadowMap.type = THREE.PCFShadowMap;
    renderer.setClearColor('#14171b');
    renderer.domElement.tabIndex = 0;

    const scene = this.scene;
    scene.background = new THREE.Color('#14171b');
    this.camera.up.set(0, 0, 1);
    const controls = new OrbitControls(this.camera, renderer.domElement);
    controls.enableDamping = true;
    controls.dampingFactor = 0.12;
    controls.maxPolarAngle = Math.PI * 0.495;
    controls.minDistance = 100;
    controls.maxDistance = 20000;
    controls.addEventListener('change', () => {
      this.dirty = true;
    });
    this.controls = controls;

    const hemi = new THREE.HemisphereLight('#dfe7f2', '#1a1d22', 1.4);
    hemi.position.set(0, 0, 1);
    scene.add(hemi);
    const sun = this.sun;
    sun.position.set(700, -500, 1600);
    sun.castShadow = true;
    sun.shadow.mapSize.set(2048, 2048);
    sun.shadow.bias = -0.0005;
    scene.add(sun);
    scene.add(sun.target);

    scene.add(this.floorGroup);
    scene.add(this.stationGroup);
    scene.add(this.slotWaferGroup);

    this.materials = new Materials();
    this.waferGeo = zCylinder(WAFER_R, WAFER_T, 96);
  }

  /**
   * Draw `robot` instead of the robot drawn before (which is freed), with a wafer on the
   * blades `wafers` says, and a floor for its reach. Returns the new drawing, not yet posed.
   */
  setRobot(robot: RobotInfo, wafers: BladeWafers): RobotModel {
    if (this.robot) {
      this.scene.remove(this.robot.root);
      this.robot.dispose();
    }
    const model = new RobotModel(robot, this.materials, this.waferGeo, wafers);
    this.robot = model;
    this.scene.add(model.root);
    this.buildFloor(model.reach);
    this.dirty = true;
    return model;
  }

  /** The floor, its grids and the base axes, sized for an arm of this reach [mm]. */
  buildFloor(reach: number): void {
    const floorGroup = this.floorGroup;
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
    const s = this.sun.shadow.camera;
    s.left = -size / 2;
    s.right = size / 2;
    s.top = size / 2;
    s.bottom = -size / 2;
    s.near = 10;
    s.far = 6000;
    s.updateProjectionMatrix();
  }

  /** Point the camera at the robot from the default corner, or from above (`top`). */
  fitCamera(reach: number, top = false): void {
    const camera = this.camera;
    const r = Math.max(500, reach);
    const target = new THREE.Vector3(0, 0, BASE_H * 0.8);
    if (top) camera.position.set(0, -r * 0.02, BASE_H + r * 3.4);
    else camera.position.set(r * 1.8, -r * 2.2, BASE_H + r * 1.5);
    this.controls.target.copy(target);
    camera.near = Math.max(1, r / 100);
    camera.far = r * 60;
    camera.updateProjectionMatrix();
    this.controls.update();
    this.dirty = true;
  }

  /** Add a station box; returns its id (the name, made unique). */
  addStation(spec: StationSpec): string {
    const stations = this.stations;
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
    this.stationGroup.add(grp);
    stations.set(id, grp);
    this.dirty = true;
    return id;
  }

  removeStation(id: string): void {
    const o = this.stations.get(id);
    if (!o) return;
    this.stationGroup.remove(o);
    disposeObject(o);
    this.stations.delete(id);
    this.dirty = true;
  }

  clearStations(): void {
    for (const id of [...this.stations.keys()]) this.removeStation(id);
  }

  /** The wafers in the stations, replacing those drawn before. */
  setStationWafers(discs: readonly WaferDisc[]): void {
    const mats = this.materials;
    const slotWafers = this.slotWafers;
    while (slotWafers.length < discs.length) {
      const m = new THREE.Mesh(this.waferGeo, mats.wafer);
      m.castShadow = false;
      m.receiveShadow = true;
      m.renderOrder = 1;
      this.slotWaferGroup.add(m);
      slotWafers.push(m);
    }
    slotWafers.forEach((m, i) => {
      const d = discs[i];
      m.visible = d !== undefined;
      if (!d) return;
      m.material =
        d.state === 'double'
          ? mats.double
          : d.state === 'cross'
            ? mats.cross
            : d.state === 'uncertain'
              ? mats.uncertain
              : mats.wafer;
      m.position.set(d.x, d.y, sceneZ(d.z) + WAFER_GAP);
      // Yaw about +Z, then a cross-slotted wafer's tilt about the station's hand direction.
      m.rotation.set(THREE.MathUtils.degToRad(d.tilt), 0, THREE.MathUtils.degToRad(d.yaw), 'ZYX');
      m.scale.set(1, 1, d.state === 'double' ? DOUBLE_SCALE : 1);
      m.name = `${d.station}.${d.slot}`;
    });
    this.dirty = true;
  }

  /**
   * What the stations' wafers look like now, read back from the scene (for tests and the
   * console): `LP2.1` → `wafer`, `double`, `cross` or `uncertain`.
   */
  drawnSlotWafers(): Record<string, string> {
    const mats = this.materials;
    const out: Record<string, string> = {};
    for (const m of this.slotWafers) {
      if (!m.visible) continue;
      const look =
        m.material === mats.uncertain ? 'uncertain' : m.material === mats.double ? 'double' : m.material === mats.cross ? 'cross' : 'wafer';
      out[m.name] = look;
    }
    return out;
  }

  /** Size the canvas to `width` × `height` [CSS px]; ignored while hidden (0) or unchanged. */
  setSize(width: number, height: number): void {
    if (width <= 0 || height <= 0) return;
    if (width === this.width && height === this.height) return;
    this.width = width;
    this.height = height;
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.dirty = true;
  }

  /** Whether the canvas has been sized. */
  sized(): boolean {
    return this.width > 0;
  }

  /** Forget the size, so that the next `setSize` applies it even when it did not change. */
  forgetSize(): void {
    this.width = 0;
  }

  /** Advance the orbit controls' damping (once per frame). */
  updateControls(): void {
    if (this.controls.update()) this.dirty = true;
  }

  /** Render if something changed and the canvas has a size. */
  render(): void {
    if (!this.dirty || this.width === 0) return;
    this.dirty = false;
    this.renderer.render(this.scene, this.camera);
  }

  dispose(): void {
    this.controls.dispose();
    this.robot?.dispose();
    disposeObject(this.scene);
    this.renderer.dispose();
  }
}
