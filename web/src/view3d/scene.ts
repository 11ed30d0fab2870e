// The 3D view's scene: renderer, camera and its orbit (orbit.ts), lights, the floor grid, the drawn
// robot, the stations as translucent boxes (with their names), fixed obstacles, and the
// wafers in the stations. It renders only when something changed (`invalidate`, which asks
// the simulator panel for a frame); what to draw comes from simulator.ts.
//
// What it costs: the stations' wafers are instanced (one draw call per look — a wafer, a
// double, a cross-slotted, an uncertain one — however many slots hold one: LP1's 25 are one);
// the shadow map is drawn again only when the robot moved or the scene changed, never for a
// camera move; a software renderer (no graphics card) gets no antialiasing, 0.6 pixels per CSS
// pixel, at most 12 frames a second and a small hard-edged shadow map (`RenderQuality`): its
// frames cost the CPU the controller runs on. It needs no DOM: it runs in
// the render worker on an OffscreenCanvas (scene-host.ts), or on the page.

import * as THREE from 'three';
import type { RobotInfo } from '../protocol/bus';
import { frameCamera, type Footprint } from './camera-frame';
import { Materials } from './materials';
import { orbitMove, orbitOf, orbitPosition, type Orbit } from './orbit';
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
  /**
   * The half-width of the open channel on the box's mouth face (its -x face, towards the
   * robot) through which the hand enters [mm] (from the controller's solid volume; absent:
   * not drawn).
   */
  opening?: number;
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

/** How the renderer draws: what a PC with or without a graphics card can afford. */
export interface RenderQuality {
  /** `gpu`: a graphics card; `software`: a software renderer (SwiftShader, llvmpipe). */
  tier: 'gpu' | 'software';
  antialias: boolean;
  /** Device pixels per CSS pixel. */
  pixelRatio: number;
  /** Shadow map size [px] (0: no shadows). */
  shadowMapSize: number;
  /** Soft (PCF) shadow edges. */
  softShadows: boolean;
  /** The most frames drawn a second while something moves. */
  maxFps: number;
}

/** The renderer's name says it draws on the CPU. */
export function isSoftwareRenderer(name: string): boolean {
  return /swiftshader|llvmpipe|softpipe|software|microsoft basic render/i.test(name);
}

/** What to draw with for a renderer `name` (from WEBGL_debug_renderer_info) and a display's pixel ratio. */
export function renderQuality(name: string, devicePixelRatio: number): RenderQuality {
  if (isSoftwareRenderer(name)) {
    return { tier: 'software', antialias: false, pixelRatio: 0.6, shadowMapSize: 512, softShadows: false, maxFps: 12 };
  }
  return {
    tier: 'gpu',
    antialias: true,
    pixelRatio: Math.min(Math.max(1, devicePixelRatio || 1), 2),
    shadowMapSize: 2048,
    softShadows: true,
    maxFps: 60,
  };
}

/** A fixed obstacle of the cell (`EVT OBSTACLE`), in the base frame [mm, deg]. */
export type ObstacleSpec =
  | { name: string; kind: 'box'; x: number; y: number; yaw: number; depth: number; width: number; bottom: number; top: number }
  | { name: string; kind: 'cylinder'; x: number; y: number; radius: number; bottom: number; top: number };

/** The looks a station's wafer is drawn with, each one InstancedMesh. */
const LOOKS = ['wafer', 'double', 'cross', 'uncertain'] as const;
type Look = (typeof LOOKS)[number];

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
  private dirty = true;
  /** The shadows must be drawn again (the robot moved, the scene changed). */
  private shadowsStale = true;
  /** Called when something changed: the panel schedules a frame. */
  onInvalidate: () => void = () => undefined;
  /** The operator moved the camera since the default view was set. */
  cameraMoved = false;
  /** The camera's place about what it looks at. */
  private orbit: Orbit = { target: { x: 0, y: 0, z: 0 }, azimuth: 0, polar: 1, distance: 1000 };
  private readonly sun = new THREE.DirectionalLight('#ffffff', 2.2);
  private readonly floorGroup = new THREE.Group();
  private readonly stationGroup = new THREE.Group();
  private readonly slotWaferGroup = new THREE.Group();
  private readonly obstacleGroup = new THREE.Group();
  /** One wafer geometry for the hand and every slot (not disposed with a robot model). */
  private readonly waferGeo: THREE.CylinderGeometry;
  private readonly stations = new Map<string, THREE.Object3D>();
  /** The stations' wafers: one InstancedMesh per look, grown when too small, placed when the map changes. */
  private readonly slotWafers = new Map<Look, THREE.InstancedMesh>();
  /** What each drawn slot shows (`LP2.1` → `uncertain`), for tests and the console. */
  private slotLooks: Record<string, Look> = {};
  /** Where each station's name is drawn: the top of its box, in the scene. */
  readonly labelAnchors = new Map<string, THREE.Vector3>();
  private readonly stationSpecs = new Map<string, StationSpec>();
  /** The canvas size [CSS px]; 0 until known (or to be measured again). */
  private width = 0;
  private height = 0;

  constructor(
    private readonly renderer: THREE.WebGLRenderer,
    readonly quality: RenderQuality,
  ) {
    renderer.setPixelRatio(quality.pixelRatio);
    renderer.shadowMap.enabled = quality.shadowMapSize > 0;
    renderer.shadowMap.type = quality.softShadows ? THREE.PCFSoftShadowMap : THREE.BasicShadowMap;
    // Drawn again only when something that casts a shadow moved (`render`).
    renderer.shadowMap.autoUpdate = false;
    renderer.setClearColor('#14171b');

    const scene = this.scene;
    scene.background = new THREE.Color('#14171b');
    this.camera.up.set(0, 0, 1);
    const hemi = new THREE.HemisphereLight('#dfe7f2', '#1a1d22', 1.4);
    hemi.position.set(0, 0, 1);
    scene.add(hemi);
    const sun = this.sun;
    sun.position.set(700, -500, 1600);
    sun.castShadow = quality.shadowMapSize > 0;
    sun.shadow.mapSize.set(Math.max(1, quality.shadowMapSize), Math.max(1, quality.shadowMapSize));
    sun.shadow.bias = -0.0005;
    scene.add(sun);
    scene.add(sun.target);

    scene.add(this.floorGroup);
    scene.add(this.stationGroup);
    scene.add(this.slotWaferGroup);
    scene.add(this.obstacleGroup);

    this.materials = new Materials();
    this.waferGeo = zCylinder(WAFER_R, WAFER_T, quality.tier === 'software' ? 48 : 96);
  }

  /** Something changed: render at the next frame (`shadows`: the shadow map too). */
  invalidate(shadows = true): void {
    this.dirty = true;
    if (shadows) this.shadowsStale = true;
    this.onInvalidate();
  }

  /** Whether a render is due. */
  needsRender(): boolean {
    return this.dirty;
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
    this.invalidate();
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

  /**
   * Point the camera at the robot and the station it works at (camera-frame.ts: the
   * station of `working`, else the one nearest `hand`), from the side where no other station
   * hides them; or from above (`top`). Without stations: the robot from a corner.
   */
  fitCamera(reach: number, top = false, hand: { x: number; y: number } | null = null, working: string | null = null): void {
    const camera = this.camera;
    const r = Math.max(500, reach);
    const footprints: Footprint[] = [...this.stationSpecs.values()].map((s) => ({
      name: s.name,
      x: s.x,
      y: s.y,
      yaw: s.yaw ?? 0,
      depth: s.depth,
      width: s.width,
    }));
    const f = frameCamera(footprints, hand, working, reach);
    const z0 = BASE_H * 0.8;
    if (top) {
      this.orbit = orbitOf({ x: 0, y: -r * 0.02, z: BASE_H + r * 3.4 }, { x: 0, y: 0, z: z0 });
    } else if (f.station === null) {
      this.orbit = orbitOf({ x: r * 1.8, y: -r * 2.2, z: BASE_H + r * 1.5 }, { x: 0, y: 0, z: z0 });
    } else {
      // Looked at from 30° above, far enough for the frame's radius in the 40° view.
      const dist = (f.radius / Math.tan((camera.fov * Math.PI) / 360)) * 1.5;
      this.orbit = {
        target: { x: f.target.x, y: f.target.y, z: z0 },
        azimuth: (f.azimuth * Math.PI) / 180,
        polar: (60 * Math.PI) / 180,
        distance: dist,
      };
    }
    camera.near = Math.max(1, r / 100);
    camera.far = r * 60;
    camera.updateProjectionMatrix();
    this.placeCamera();
    this.cameraMoved = false;
    this.invalidate(false);
  }

  /** Put the camera where its orbit says. */
  private placeCamera(): void {
    const p = orbitPosition(this.orbit);
    this.camera.position.set(p.x, p.y, p.z);
    this.camera.lookAt(this.orbit.target.x, this.orbit.target.y, this.orbit.target.z);
  }

  /** The operator moved the camera: a drag (`rotate`, `pan`) or the wheel (`zoom`) [CSS px]. */
  orbitBy(kind: 'rotate' | 'pan' | 'zoom', dx: number, dy: number): void {
    this.orbit = orbitMove(this.orbit, kind, dx, dy, this.height || 600, this.camera.fov);
    this.cameraMoved = true;
    this.placeCamera();
    this.invalidate(false);
  }

  /** Where each station's name goes on the canvas [CSS px], and whether it is in view. */
  labelPositions(): { id: string; x: number; y: number; visible: boolean }[] {
    const v = new THREE.Vector3();
    const out: { id: string; x: number; y: number; visible: boolean }[] = [];
    for (const [id, anchor] of this.labelAnchors) {
      v.copy(anchor).project(this.camera);
      const visible = v.z < 1 && Math.abs(v.x) <= 1.05 && Math.abs(v.y) <= 1.05;
      out.push({ id, x: ((v.x + 1) / 2) * this.width, y: ((1 - v.y) / 2) * this.height, visible });
    }
    return out;
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
    if (spec.opening !== undefined && spec.opening > 0) {
      // The open channel on the mouth face: where the hand may enter.
      const hw = Math.max(1, Math.min(spec.opening, spec.width / 2));
      const x = -Math.max(1, spec.depth) / 2 - 0.5;
      const hz = Math.max(1, spec.height) / 2;
      const frame = new THREE.BufferGeometry().setFromPoints([
        new THREE.Vector3(x, -hw, -hz),
        new THREE.Vector3(x, -hw, hz),
        new THREE.Vector3(x, hw, hz),
        new THREE.Vector3(x, hw, -hz),
      ]);
      grp.add(new THREE.LineLoop(frame, new THREE.LineBasicMaterial({ color: '#ffd27a' })));
    }
    grp.name = id;
    this.stationGroup.add(grp);
    stations.set(id, grp);
    this.stationSpecs.set(id, spec);
    this.labelAnchors.set(id, new THREE.Vector3(spec.x, spec.y, bottom + Math.max(1, spec.height) + 12));
    this.invalidate();
    return id;
  }

  removeStation(id: string): void {
    const o = this.stations.get(id);
    if (!o) return;
    this.stationGroup.remove(o);
    disposeObject(o);
    this.stations.delete(id);
    this.stationSpecs.delete(id);
    this.labelAnchors.delete(id);
    this.invalidate();
  }

  clearStations(): void {
    for (const id of [...this.stations.keys()]) this.removeStation(id);
  }

  /** The fixed obstacles of the cell (`EVT OBSTACLE`), replacing those drawn before. */
  setObstacles(list: readonly ObstacleSpec[]): void {
    for (const c of [...this.obstacleGroup.children]) {
      this.obstacleGroup.remove(c);
      disposeObject(c);
    }
    for (const o of list) {
      const height = Math.max(1, o.top - o.bottom);
      const geo =
        o.kind === 'box'
          ? new THREE.BoxGeometry(Math.max(1, o.depth), Math.max(1, o.width), height)
          : new THREE.CylinderGeometry(Math.max(1, o.radius), Math.max(1, o.radius), height, 32).rotateX(Math.PI / 2);
      const mesh = new THREE.Mesh(
        geo,
        new THREE.MeshStandardMaterial({ color: '#8a6d5a', transparent: true, opacity: 0.45, depthWrite: false, roughness: 0.9 }),
      );
      const edges = new THREE.LineSegments(new THREE.EdgesGeometry(geo), new THREE.LineBasicMaterial({ color: '#c9a58c' }));
      const grp = new THREE.Group();
      grp.add(mesh, edges);
      grp.position.set(o.x, o.y, sceneZ(o.bottom) + height / 2);
      if (o.kind === 'box') grp.rotation.z = THREE.MathUtils.degToRad(o.yaw);
      grp.name = o.name;
      this.obstacleGroup.add(grp);
    }
    this.invalidate();
  }

  /** The InstancedMesh of `look`, with room for at least `n` wafers. */
  private instances(look: Look, n: number): THREE.InstancedMesh {
    let m = this.slotWafers.get(look);
    if (m && m.instanceMatrix.count >= n) return m;
    if (m) {
      this.slotWaferGroup.remove(m);
      m.dispose();
    }
    const mats = this.materials;
    const material = look === 'double' ? mats.double : look === 'cross' ? mats.cross : look === 'uncertain' ? mats.uncertain : mats.wafer;
    m = new THREE.InstancedMesh(this.waferGeo, material, Math.max(8, n, 2 * (m?.instanceMatrix.count ?? 0)));
    m.castShadow = false;
    m.receiveShadow = this.quality.tier === 'gpu';
    m.renderOrder = 1;
    m.count = 0;
    m.frustumCulled = false;
    this.slotWaferGroup.add(m);
    this.slotWafers.set(look, m);
    return m;
  }

  /** The wafers in the stations, replacing those drawn before. */
  setStationWafers(discs: readonly WaferDisc[]): void {
    const byLook = new Map<Look, WaferDisc[]>(LOOKS.map((l) => [l, []]));
    for (const d of discs) byLook.get(d.state)?.push(d);
    const o = new THREE.Object3D();
    const looks: Record<string, Look> = {};
    for (const look of LOOKS) {
      const list = byLook.get(look) ?? [];
      const m = list.length > 0 ? this.instances(look, list.length) : this.slotWafers.get(look);
      if (!m) continue;
      list.forEach((d, i) => {
        o.position.set(d.x, d.y, sceneZ(d.z) + WAFER_GAP);
        // Yaw about +Z, then a cross-slotted wafer's tilt about the station's hand direction.
        o.rotation.set(THREE.MathUtils.degToRad(d.tilt), 0, THREE.MathUtils.degToRad(d.yaw), 'ZYX');
        o.scale.set(1, 1, d.state === 'double' ? DOUBLE_SCALE : 1);
        o.updateMatrix();
        m.setMatrixAt(i, o.matrix);
        looks[`${d.station}.${d.slot}`] = look;
      });
      m.count = list.length;
      m.instanceMatrix.needsUpdate = true;
    }
    this.slotLooks = looks;
    this.invalidate();
  }

  /**
   * What the stations' wafers look like now (for tests and the console): `LP2.1` → `wafer`,
   * `double`, `cross` or `uncertain`.
   */
  drawnSlotWafers(): Record<string, string> {
    return { ...this.slotLooks };
  }

  /** Draw calls the stations' wafers take (one per look in use), for tests and the console. */
  slotWaferDrawCalls(): number {
    let n = 0;
    for (const m of this.slotWafers.values()) if (m.count > 0) n++;
    return n;
  }

  /** Size the canvas to `width` × `height` [CSS px]; ignored while hidden (0) or unchanged. */
  setSize(width: number, height: number): void {
    if (width <= 0 || height <= 0) return;
    if (width === this.width && height === this.height) return;
    this.width = width;
    this.height = height;
    // An OffscreenCanvas has no style to set: only its drawing buffer is sized.
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.invalidate(false);
  }

  /** Whether the canvas has been sized. */
  sized(): boolean {
    return this.width > 0;
  }

  /** Forget the size, so that the next `setSize` applies it even when it did not change. */
  forgetSize(): void {
    this.width = 0;
  }

  /** The robot was posed anew: draw it (and its shadow) at the next frame. */
  robotMoved(): void {
    this.invalidate(true);
  }

  /** Render if something changed and the canvas has a size; true when it rendered. */
  render(): boolean {
    if (!this.dirty || this.width === 0) return false;
    this.dirty = false;
    if (this.shadowsStale) {
      this.renderer.shadowMap.needsUpdate = true;
      this.shadowsStale = false;
    }
    this.renderer.render(this.scene, this.camera);
    return true;
  }

  dispose(): void {
    this.robot?.dispose();
    disposeObject(this.scene);
    this.renderer.dispose();
  }
}
