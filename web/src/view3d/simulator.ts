// Simulator panel (the paper's Fig. 5): a three.js view of the robot built from `ROBOT`
// (bus.robot / bus.onRobot) and animated from the simulator datagrams (bus.onSample), or, while
// the trace viewer has a trace open, the recorded robot at its scrubber (showRecorded).
//
// This module wires the parts together and draws on demand: the scene (scene.ts) with the
// drawn robot (robot-model.ts), the live datagrams (live-stream.ts), the text overlay
// (overlay.ts) and the stations' names. Nothing runs at rest: a frame is asked for only when
// a datagram changed something, the camera moved, the view was resized or the scene changed,
// and drawn at most `RenderQuality.maxFps` times a second, never while the GPU (or the
// software renderer) has not finished the last one: the page's main thread stays free for
// the operator's clicks, the E-STOP first.

import * as THREE from 'three';
import type { Bus, RobotInfo, RobotState, SimSample } from '../protocol/bus';
import { h } from '../dom';
import { LiveStream } from './live-stream';
import { drawOverlay } from './overlay';
import { SimScene, renderQuality, type ObstacleSpec, type RenderQuality, type StationSpec, type WaferDisc } from './scene';
import { armPose, homePositions, type ArmPose } from './sim-kinematics';
import './simulator.css';

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
  /**
   * Show or hide the wafer on the hand (shown by default); an `uncertain` one (perhaps there,
   * after an interrupted transfer) is drawn amber, hatched, with a `?`.
   */
  setWafer(onHand: boolean, uncertain?: boolean): void;
  /** Show or hide the wafer on blade B of a dual-blade robot (hidden by default; no-op without one). */
  setBladeBWafer(onBladeB: boolean, uncertain?: boolean): void;
  /**
   * The wafers in the stations (replacing those drawn before); call when the map or the
   * stations change, not per frame.
   */
  setStationWafers(discs: readonly WaferDisc[]): void;
  /** The fixed obstacles of the cell (replacing those drawn before). */
  setObstacles(list: readonly ObstacleSpec[]): void;
  /** The station of the transfer in progress (null: none): the default camera frames it. */
  setWorkingStation(name: string | null): void;
  /** Draw the view inside `el` (the Simulator tab, or beside the wafer map). */
  moveTo(el: HTMLElement): void;
  /** How the view draws (for tests and the console). */
  quality(): RenderQuality | null;
  /** Frames drawn so far (for tests and the console: none at rest). */
  framesDrawn(): number;
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
  /**
   * How the wafers are drawn now, read back from the scene (for tests and the console): each
   * blade's (`none`, `wafer`, `uncertain`; blade B null on a single-hand robot) and each
   * station slot's that shows one (`LP2.1` → `wafer`, `double`, `cross`, `uncertain`).
   */
  drawnWafers(): { hand: string | null; bladeB: string | null; slots: Record<string, string> };
  /** Remove the view and stop everything (not needed by the app; for tests and reuse). */
  dispose(): void;
}

/** True when the browser can give three.js a WebGL 2 context. */
export function webglAvailable(): boolean {
  return webglRenderer() !== null;
}

/** The WebGL 2 renderer's name (`ANGLE (Google, Vulkan … SwiftShader …)`), '' when it is not told; null without WebGL 2. */
function webglRenderer(): string | null {
  try {
    const c = h('canvas');
    const gl = c.getContext('webgl2');
    if (!gl) return null;
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : String(gl.getParameter(gl.RENDERER));
    // Give the probe's context back at once: browsers allow only a few at a time.
    gl.getExtension('WEBGL_lose_context')?.loseContext();
    return name;
  } catch {
    return null;
  }
}

/** Whether two samples draw the same robot (same joints and state). */
function sameDrawing(a: SimSample | null, b: SimSample): boolean {
  if (!a || a.state !== b.state || a.positions.length !== b.positions.length) return false;
  for (let i = 0; i < a.positions.length; i++) if (Math.abs(a.positions[i] - b.positions[i]) > 1e-6) return false;
  return true;
}

export function mountSimulator(el: HTMLElement, bus: Bus): SimulatorHandle {
  const root = el.appendChild(h('div', { class: 'sim-root' }));
  const msg = root.appendChild(h('div', { class: 'sim-msg' }));
  const msgBox = msg.appendChild(h('div', { class: 'sim-msg-box' }));
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
    setObstacles() {},
    setWorkingStation() {},
    moveTo(target) {
      target.append(root);
    },
    quality: () => null,
    framesDrawn: () => 0,
    showRecorded() {},
    drawnPose: () => null,
    drawnWafers: () => ({ hand: null, bladeB: null, slots: {} }),
    dispose() {
      root.remove();
    },
  };

  const rendererName = webglRenderer();
  if (rendererName === null) {
    showMessage(
      '3D simulator unavailable: this browser has no WebGL 2 (it may be disabled, or no GPU ' +
        'driver is available). Control, Editor and Plots keep working.',
      true,
    );
    return noop;
  }
  const quality = renderQuality(rendererName, window.devicePixelRatio);
  let renderer: THREE.WebGLRenderer;
  try {
    renderer = new THREE.WebGLRenderer({ antialias: quality.antialias, powerPreference: 'low-power' });
  } catch (e) {
    showMessage(`3D simulator unavailable: WebGL could not be started (${String(e)}).`, true);
    return noop;
  }
  const view = new SimScene(renderer, quality);
  root.insertBefore(renderer.domElement, msg);
  root.setAttribute('data-quality', quality.tier);
  const labels = root.appendChild(h('div', { class: 'sim-labels', 'aria-hidden': 'true' }));

  // Overlay and buttons.
  const overlay = root.appendChild(h('div', { class: 'sim-overlay' }));
  const buttons = root.appendChild(h('div', { class: 'sim-buttons' }));
  const button = (label: string, title: string, fn: () => void): void => {
    buttons.append(h('button', { type: 'button', title, onclick: fn }, label));
  };

  let waferOnHand = true;
  let waferOnBladeB = false;
  let handUncertain = false;
  let bladeBUncertain = false;
  /** While set, the view draws this instead of the live datagrams. */
  let recorded: RecordedFrame | null = null;
  let state: RobotState = 'IDLE';
  let disposed = false;
  let working: string | null = null;
  let frames = 0;
  // The frame loop's state (frames are asked for from the listeners below).
  /** The fence after the last frame: the next waits until the GPU has finished it. */
  let fence: WebGLSync | null = null;
  let raf = 0;
  let lastFrame = -Infinity;
  let lastOverlay = 0;
  let overlayDue = false;
  const live = new LiveStream(bus, () => {
    updateOverlay(performance.now());
    requestFrame();
  });
  /** The datagram whose pose and state are drawn (null: none yet, or a recorded frame). */
  let drawnSample: SimSample | null = null;
  // A datagram that changes nothing drawn asks for no frame (at rest: none at all).
  const unsubSample = bus.onSample((smp) => {
    if (recorded === null && !sameDrawing(drawnSample, smp)) requestFrame();
    else overlayDue = true;
  });
  view.onInvalidate = () => requestFrame();

  function applyState(s: RobotState): void {
    state = s;
    view.materials.tint(s);
    view.invalidate(false);
  }

  function setRobot(robot: RobotInfo): void {
    const first = view.robot === null;
    const model = view.setRobot(robot, { hand: waferOnHand, bladeB: waferOnBladeB, handUncertain, bladeBUncertain });
    model.pose(armPose(model.axes, live.applied?.positions ?? live.latest?.positions ?? homePositions(robot)));
    drawnSample = recorded === null ? (live.applied ?? live.latest) : null;
    if (first || !view.cameraMoved) defaultCamera();
    view.robotMoved();
    updateOverlay(performance.now());
  }

  /** The default camera: the robot and the station it works at. */
  function defaultCamera(): void {
    const s = live.latest;
    view.fitCamera(view.robot?.reach ?? 600, false, s ? { x: s.x, y: s.y } : null, working);
  }
  button('Top', 'View from above', () => view.fitCamera(view.robot?.reach ?? 600, true));
  button('Reset view', 'Back to the default camera: the robot and the station it works at', () => defaultCamera());
  button('Reset counts', 'Reset the lost-datagram counters', () => {
    live.stats.reset();
    updateOverlay(performance.now());
  });

  function updateOverlay(now: number): void {
    const model = view.robot;
    drawOverlay(overlay, {
      robot: model?.robot ?? bus.robot(),
      drawn: model,
      connected: live.connected,
      live: recorded === null ? live.applied : null,
      recorded,
      rateHz: live.stats.rate(now),
      lost: live.stats.lost,
      gaps: live.stats.gaps,
    });
    if (!model) showMessage(live.connected ? 'Waiting for the robot description (ROBOT)…' : 'Not connected to the controller.');
    else showMessage(null);
  }

  // A recorded frame keeps its own robot; the live one is drawn again when it ends.
  const unsubRobot = bus.onRobot((r) => {
    if (recorded === null) setRobot(r);
  });
  const r0 = bus.robot();
  if (r0) setRobot(r0);
  else {
    view.buildFloor(600);
    view.fitCamera(600);
  }
  applyState(state);

  // Size.
  function resize(): void {
    if (disposed) return;
    view.setSize(root.clientWidth, root.clientHeight);
  }
  const ro = typeof ResizeObserver !== 'undefined' ? new ResizeObserver(() => resize()) : null;
  ro?.observe(root);

  let contextLost = false;
  renderer.domElement.addEventListener('webglcontextlost', (e) => {
    e.preventDefault();
    contextLost = true;
    showMessage('3D view lost its WebGL context; it resumes when the browser restores it.', true);
  });
  renderer.domElement.addEventListener('webglcontextrestored', () => {
    contextLost = false;
    view.invalidate();
    showMessage(null);
  });

  // ---- drawing on demand ----
  const gl = renderer.getContext() as WebGL2RenderingContext;
  const minFrameMs = 1000 / quality.maxFps;

  function visible(): boolean {
    return root.isConnected && root.offsetParent !== null && !(typeof document !== 'undefined' && document.hidden);
  }

  /** Ask for a frame (no-op while one is asked for). */
  function requestFrame(): void {
    if (raf !== 0 || disposed) return;
    raf = requestAnimationFrame(frame);
  }

  /** Whether the GPU has finished the last frame (no fence: yes). */
  function gpuDone(): boolean {
    if (fence === null) return true;
    try {
      if (gl.getSyncParameter(fence, gl.SYNC_STATUS) !== gl.SIGNALED) return false;
    } catch {
      /* no sync objects: draw */
    }
    gl.deleteSync(fence);
    fence = null;
    return true;
  }

  function frame(now: number): void {
    raf = 0;
    if (disposed || !visible()) return; // shown again: resize() asks for a frame
    if (!view.sized()) resize();
    // Not before the GPU is done with the last frame, nor more often than maxFps: the
    // main thread stays free.
    if (!gpuDone() || now - lastFrame < minFrameMs) {
      requestFrame();
      return;
    }
    const s = recorded === null ? live.takeNew() : null;
    if (s !== null && !sameDrawing(drawnSample, s)) {
      drawnSample = s;
      view.robot?.pose(armPose(view.robot.axes, s.positions));
      if (s.state !== state) applyState(s.state);
      view.robotMoved();
    }
    const gliding = view.updateControls();
    if (overlayDue || now - lastOverlay > 250) {
      lastOverlay = now;
      overlayDue = false;
      updateOverlay(now);
    }
    if (!contextLost && view.render()) {
      lastFrame = now;
      frames++;
      placeLabels();
      try {
        fence = gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
      } catch {
        fence = null;
      }
    }
    // The camera still glides, or a datagram that changes the drawing came meanwhile: another frame.
    if (gliding || view.needsRender() || (recorded === null && live.latest !== null && !sameDrawing(drawnSample, live.latest))) {
      requestFrame();
    }
  }

  // ---- the stations' names, placed after each frame ----
  const labelEls = new Map<string, HTMLElement>();
  const v3 = new THREE.Vector3();
  function placeLabels(): void {
    const w = root.clientWidth;
    const ht = root.clientHeight;
    for (const [id, anchor] of view.labelAnchors) {
      let l = labelEls.get(id);
      if (!l) {
        l = labels.appendChild(h('span', { class: 'sim-label', 'data-testid': 'sim-label', 'data-station': id }, id));
        labelEls.set(id, l);
      }
      v3.copy(anchor).project(view.camera);
      const onScreen = v3.z < 1 && Math.abs(v3.x) <= 1.05 && Math.abs(v3.y) <= 1.05;
      l.hidden = !onScreen;
      if (onScreen) l.style.transform = `translate(${((v3.x + 1) / 2) * w}px, ${((1 - v3.y) / 2) * ht}px) translate(-50%, -100%)`;
    }
    for (const [id, l] of labelEls) {
      if (view.labelAnchors.has(id)) continue;
      l.remove();
      labelEls.delete(id);
    }
  }

  function showRecorded(frame: RecordedFrame | null): void {
    recorded = frame;
    if (frame !== null) {
      if (view.robot?.robot !== frame.robot) setRobot(frame.robot);
      view.robot?.pose(armPose(view.robot.axes, frame.positions));
      applyState(frame.state ?? 'IDLE');
    } else {
      const robot = bus.robot();
      if (robot && view.robot?.robot !== robot) setRobot(robot);
      // The next frame applies the latest datagram again.
      live.redraw();
      drawnSample = null;
      requestFrame();
      const model = view.robot;
      if (model) model.pose(armPose(model.axes, live.latest?.positions ?? homePositions(model.robot)));
      applyState(live.latest?.state ?? 'IDLE');
    }
    view.robotMoved();
    updateOverlay(performance.now());
  }

  resize();
  updateOverlay(performance.now());

  return {
    resize() {
      view.forgetSize(); // force: the container may have been hidden at the same size
      resize();
      view.invalidate(false);
    },
    addStation: (spec) => {
      const id = view.addStation(spec);
      if (!view.cameraMoved && view.robot) defaultCamera();
      return id;
    },
    removeStation: (id) => view.removeStation(id),
    clearStations: () => view.clearStations(),
    setWafer(onHand: boolean, uncertain = false) {
      if (onHand === waferOnHand && uncertain === handUncertain) return;
      waferOnHand = onHand;
      handUncertain = uncertain;
      view.robot?.showWafer(onHand, uncertain);
      view.invalidate();
    },
    setBladeBWafer(onBladeB: boolean, uncertain = false) {
      if (onBladeB === waferOnBladeB && uncertain === bladeBUncertain) return;
      waferOnBladeB = onBladeB;
      bladeBUncertain = uncertain;
      view.robot?.showBladeBWafer(onBladeB, uncertain);
      view.invalidate();
    },
    setStationWafers: (discs) => view.setStationWafers(discs),
    setObstacles: (list) => view.setObstacles(list),
    setWorkingStation(name) {
      working = name;
    },
    moveTo(target) {
      if (root.parentElement === target) return;
      target.append(root);
      view.forgetSize();
      resize();
      view.invalidate(false);
    },
    quality: () => quality,
    framesDrawn: () => frames,
    showRecorded,
    drawnPose: () => view.robot?.drawnPose() ?? null,
    drawnWafers: () => {
      const blades = view.robot?.drawnBladeWafers() ?? null;
      return { hand: blades?.hand ?? null, bladeB: blades?.bladeB ?? null, slots: view.drawnSlotWafers() };
    },
    dispose() {
      if (disposed) return;
      disposed = true;
      cancelAnimationFrame(raf);
      unsubRobot();
      unsubSample();
      live.dispose();
      ro?.disconnect();
      view.dispose();
      root.remove();
    },
  };
}
