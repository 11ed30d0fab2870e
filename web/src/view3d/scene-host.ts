// What draws the 3D view: the scene (scene.ts) and its frame loop, driven by messages (the
// robot, its pose, the wafers, the stations, the camera) and reporting after each frame what
// it drew. It runs in the render worker (scene-worker.ts) on an OffscreenCanvas, so that no
// frame ever blocks the page's main thread (with a software renderer, a frame's pixels take
// SwiftShader tens to hundreds of milliseconds, and the page would wait for them), or on the
// page where a browser has no OffscreenCanvas.
//
// Frames on demand only: a message that changes what is drawn asks for one; at most
// `RenderQuality.maxFps` a second, and never before the GPU has finished the last (a fence).

import * as THREE from 'three';
import type { RobotInfo, RobotState } from '../protocol/bus';
import { SimScene, type ObstacleSpec, type RenderQuality, type StationSpec, type WaferDisc } from './scene';
import { armPose, homePositions, type ArmPose } from './sim-kinematics';

/** Where the camera goes: the default view (the robot and the station it works at), or from above. */
export interface CameraAsk {
  top: boolean;
  /** The hand in plan view [mm], and the station of the transfer in progress. */
  hand: { x: number; y: number } | null;
  working: string | null;
  /** Only while the operator has not moved the camera (new stations, a new robot). */
  unlessMoved: boolean;
}

/** What the page tells the host. */
export type SceneMessage =
  | { t: 'size'; width: number; height: number }
  | { t: 'visible'; visible: boolean }
  | { t: 'robot'; robot: RobotInfo; positions: number[] | null; state: RobotState }
  | { t: 'pose'; positions: number[]; state: RobotState }
  | { t: 'blade'; blade: 'A' | 'B'; on: boolean; uncertain: boolean }
  | { t: 'slots'; discs: WaferDisc[] }
  | { t: 'stations'; specs: (StationSpec & { id: string })[] }
  | { t: 'obstacles'; list: ObstacleSpec[] }
  | { t: 'camera'; ask: CameraAsk }
  | { t: 'orbit'; kind: 'rotate' | 'pan' | 'zoom'; dx: number; dy: number };

/** What the host tells the page after each frame (and once it has started, or failed). */
export interface SceneReport {
  frames: number;
  /** The time of the last frame's render call and the longest so far [ms], in the host's thread. */
  frameMs: { lastMs: number; maxMs: number };
  pose: ArmPose | null;
  blades: { hand: string; bladeB: string | null } | null;
  slots: Record<string, string>;
  labels: { id: string; x: number; y: number; visible: boolean }[];
  /** Draw calls of the stations' wafers (one per look in use). */
  slotDrawCalls: number;
}

function samePositions(a: readonly number[] | null, b: readonly number[]): boolean {
  if (!a || a.length !== b.length) return false;
  for (let i = 0; i < a.length; i++) if (Math.abs(a[i] - b[i]) > 1e-6) return false;
  return true;
}

export class SceneHost {
  private readonly view: SimScene;
  private readonly gl: WebGL2RenderingContext;
  private readonly minFrameMs: number;
  private fence: WebGLSync | null = null;
  private raf = 0;
  private lastFrame = -Infinity;
  private visible = true;
  private frames = 0;
  private readonly frameMs = { lastMs: 0, maxMs: 0 };
  /** The pose asked for and the one drawn. */
  private want: { positions: number[]; state: RobotState } | null = null;
  private drawn: number[] | null = null;
  private state: RobotState = 'IDLE';
  private blades = { hand: true, bladeB: false, handUncertain: false, bladeBUncertain: false };

  constructor(
    renderer: THREE.WebGLRenderer,
    quality: RenderQuality,
    private readonly report: (r: SceneReport) => void,
    private readonly requestAnimationFrame: (cb: (now: number) => void) => number,
  ) {
    this.view = new SimScene(renderer, quality);
    this.gl = renderer.getContext() as WebGL2RenderingContext;
    this.minFrameMs = 1000 / quality.maxFps;
    this.view.onInvalidate = () => this.requestFrame();
    this.view.buildFloor(600);
    this.view.fitCamera(600);
  }

  handle(m: SceneMessage): void {
    const view = this.view;
    switch (m.t) {
      case 'size':
        view.forgetSize();
        view.setSize(m.width, m.height);
        break;
      case 'visible':
        this.visible = m.visible;
        if (m.visible) view.invalidate(false);
        break;
      case 'robot': {
        const first = view.robot === null;
        const model = view.setRobot(m.robot, { ...this.blades });
        const positions = m.positions ?? homePositions(m.robot);
        model.pose(armPose(model.axes, positions));
        this.drawn = positions;
        this.want = null;
        this.tint(m.state);
        if (first) view.fitCamera(model.reach);
        break;
      }
      case 'pose':
        if (samePositions(this.drawn, m.positions) && m.state === this.state) return;
        this.want = { positions: m.positions, state: m.state };
        this.requestFrame();
        break;
      case 'blade':
        if (m.blade === 'A') {
          this.blades.hand = m.on;
          this.blades.handUncertain = m.uncertain;
          view.robot?.showWafer(m.on, m.uncertain);
        } else {
          this.blades.bladeB = m.on;
          this.blades.bladeBUncertain = m.uncertain;
          view.robot?.showBladeBWafer(m.on, m.uncertain);
        }
        view.invalidate();
        break;
      case 'slots':
        view.setStationWafers(m.discs);
        break;
      case 'stations':
        view.clearStations();
        for (const s of m.specs) view.addStation({ ...s, name: s.id });
        break;
      case 'obstacles':
        view.setObstacles(m.list);
        break;
      case 'camera':
        if (m.ask.unlessMoved && view.cameraMoved) return;
        view.fitCamera(view.robot?.reach ?? 600, m.ask.top, m.ask.hand, m.ask.working);
        break;
      case 'orbit':
        view.orbitBy(m.kind, m.dx, m.dy);
        break;
    }
  }

  private tint(s: RobotState): void {
    this.state = s;
    this.view.materials.tint(s);
    this.view.invalidate(false);
  }

  private requestFrame(): void {
    if (this.raf !== 0) return;
    this.raf = this.requestAnimationFrame((now) => this.frame(now));
  }

  /** Whether the GPU has finished the last frame (no fence: yes). */
  private gpuDone(): boolean {
    const gl = this.gl;
    if (this.fence === null) return true;
    try {
      if (gl.getSyncParameter(this.fence, gl.SYNC_STATUS) !== gl.SIGNALED) return false;
    } catch {
      /* no sync objects: draw */
    }
    gl.deleteSync(this.fence);
    this.fence = null;
    return true;
  }

  private frame(now: number): void {
    this.raf = 0;
    if (!this.visible) return; // shown again: 'visible' asks for a frame
    if (!this.gpuDone() || now - this.lastFrame < this.minFrameMs) {
      this.requestFrame();
      return;
    }
    const view = this.view;
    const w = this.want;
    if (w && view.robot) {
      this.want = null;
      view.robot.pose(armPose(view.robot.axes, w.positions));
      this.drawn = w.positions;
      if (w.state !== this.state) this.tint(w.state);
      view.robotMoved();
    }
    const t0 = performance.now();
    if (view.render()) {
      this.lastFrame = now;
      this.frames++;
      this.frameMs.lastMs = performance.now() - t0;
      this.frameMs.maxMs = Math.max(this.frameMs.maxMs, this.frameMs.lastMs);
      try {
        this.fence = this.gl.fenceSync(this.gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
      } catch {
        this.fence = null;
      }
      this.report({
        frames: this.frames,
        frameMs: { ...this.frameMs },
        pose: view.robot?.drawnPose() ?? null,
        blades: view.robot?.drawnBladeWafers() ?? null,
        slots: view.drawnSlotWafers(),
        labels: view.labelPositions(),
        slotDrawCalls: view.slotWaferDrawCalls(),
      });
    }
    if (view.needsRender() || this.want !== null) this.requestFrame();
  }

  dispose(): void {
    this.view.dispose();
  }
}
