// Simulator panel (the paper's Fig. 5): a three.js view of the robot built from `ROBOT`
// (bus.robot / bus.onRobot) and animated from the simulator datagrams (bus.onSample), or, while
// the trace viewer has a trace open, the recorded robot at its scrubber (showRecorded).
//
// This module is the page's side: the canvas, the overlay, the stations' names, the buttons and
// the pointer (orbit, pan, zoom). The drawing itself is a SceneHost (scene-host.ts) in the
// render worker on an OffscreenCanvas — nothing it draws can hold up the page's main thread,
// where the E-STOP is handled — or, in a browser without OffscreenCanvas, on the page. It is
// told only what changes: a datagram that moves nothing sends nothing, so at rest nothing is
// drawn at all.

import * as THREE from 'three';
import type { Bus, RobotInfo, RobotState, SimSample } from '../protocol/bus';
import { h } from '../dom';
import { LiveStream } from './live-stream';
import { drawOverlay } from './overlay';
import { renderQuality, type ObstacleSpec, type RenderQuality, type StationSpec, type WaferDisc } from './scene';
import { SceneHost, type CameraAsk, type SceneMessage, type SceneReport } from './scene-host';
import { armAxes, type ArmPose } from './sim-kinematics';
import './simulator.css';

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
  /** Where the view draws: `worker` (an OffscreenCanvas in the render worker) or `page`; null without WebGL. */
  drawnIn(): 'worker' | 'page' | null;
  /** Draw calls the stations' wafers take (one per look in use; LP1's 25 wafers are one). */
  slotDrawCalls(): number;
  /** The main thread's time in the last frame and the longest so far [ms] (the overlay shows them). */
  frameTimes(): { lastMs: number; maxMs: number };
  /**
   * Draw a recorded robot and pose instead of the live one, until called with null: then the
   * live robot and its latest datagram again. Live datagrams keep being counted meanwhile.
   */
  showRecorded(frame: RecordedFrame | null): void;
  /**
   * The joint values the 3D view draws now [deg, deg, deg, mm], as the scene reported after
   * its last frame (for tests and the console); null before a robot is drawn or without WebGL.
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

/** Where the scene runs: a function that takes its messages. */
interface Driver {
  post(m: SceneMessage): void;
  dispose(): void;
}

/** The scene in the render worker, on `canvas` handed over as an OffscreenCanvas; null when the browser cannot. */
function workerDriver(
  canvas: HTMLCanvasElement,
  quality: RenderQuality,
  report: (r: SceneReport) => void,
  failed: (why: string) => void,
): Driver | null {
  if (typeof Worker === 'undefined' || typeof canvas.transferControlToOffscreen !== 'function') return null;
  let worker: Worker;
  let offscreen: OffscreenCanvas;
  try {
    offscreen = canvas.transferControlToOffscreen();
    worker = new Worker(new URL('./scene-worker.ts', import.meta.url), { type: 'module' });
  } catch {
    return null;
  }
  worker.onmessage = (ev: MessageEvent<{ t: 'report'; report: SceneReport } | { t: 'ready' } | { t: 'failed'; why: string }>) => {
    if (ev.data.t === 'report') report(ev.data.report);
    else if (ev.data.t === 'failed') failed(ev.data.why);
  };
  worker.onerror = (e) => failed(e.message || 'the render worker failed');
  worker.postMessage({ t: 'init', canvas: offscreen, quality }, [offscreen]);
  return {
    post: (m) => worker.postMessage(m),
    dispose: () => worker.terminate(),
  };
}

/** The scene on the page (a browser without OffscreenCanvas). */
function pageDriver(canvas: HTMLCanvasElement, quality: RenderQuality, report: (r: SceneReport) => void): Driver {
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: quality.antialias, powerPreference: 'low-power' });
  const host = new SceneHost(renderer, quality, report, (cb) => requestAnimationFrame(cb));
  return { post: (m) => host.handle(m), dispose: () => host.dispose() };
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

  const rendererName = webglRenderer();
  if (rendererName === null) {
    showMessage(
      '3D simulator unavailable: this browser has no WebGL 2 (it may be disabled, or no GPU ' +
        'driver is available). Control, Editor and Plots keep working.',
      true,
    );
    return {
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
      drawnIn: () => null,
      slotDrawCalls: () => 0,
      frameTimes: () => ({ lastMs: 0, maxMs: 0 }),
      showRecorded() {},
      drawnPose: () => null,
      drawnWafers: () => ({ hand: null, bladeB: null, slots: {} }),
      dispose() {
        root.remove();
      },
    };
  }
  const quality = renderQuality(rendererName, window.devicePixelRatio);
  root.setAttribute('data-quality', quality.tier);

  // ---- what the scene reported after its last frame ----
  let last: SceneReport | null = null;
  const labels = h('div', { class: 'sim-labels', 'aria-hidden': 'true' });
  const labelEls = new Map<string, HTMLElement>();
  function onReport(r: SceneReport): void {
    last = r;
    for (const l of r.labels) {
      let e = labelEls.get(l.id);
      if (!e) {
        e = labels.appendChild(h('span', { class: 'sim-label', 'data-testid': 'sim-label', 'data-station': l.id }, l.id));
        labelEls.set(l.id, e);
      }
      e.hidden = !l.visible;
      if (l.visible) e.style.transform = `translate(${l.x}px, ${l.y}px) translate(-50%, -100%)`;
    }
    for (const [id, e] of labelEls) {
      if (r.labels.some((l) => l.id === id)) continue;
      e.remove();
      labelEls.delete(id);
    }
  }

  // ---- the canvas and where it is drawn ----
  let canvas = h('canvas', { tabindex: '0' });
  root.insertBefore(canvas, msg);
  let where: 'worker' | 'page' = 'worker';
  let driver: Driver;
  const startOnPage = (): Driver => {
    where = 'page';
    return pageDriver(canvas, quality, onReport);
  };
  driver =
    workerDriver(canvas, quality, onReport, (why) => {
      // The worker could not draw (no WebGL there): draw on the page instead, on a new canvas.
      console.warn(`wrc: the 3D view draws on the page: ${why}`);
      driver.dispose();
      const fresh = h('canvas', { tabindex: '0' });
      canvas.replaceWith(fresh);
      canvas = fresh;
      listen(canvas);
      driver = startOnPage();
      replay();
    }) ?? startOnPage();
  root.append(labels);

  // Overlay and buttons.
  const overlay = root.appendChild(h('div', { class: 'sim-overlay' }));
  const buttons = root.appendChild(h('div', { class: 'sim-buttons' }));
  const button = (label: string, title: string, fn: () => void): void => {
    buttons.append(h('button', { type: 'button', title, onclick: fn }, label));
  };

  // ---- what the scene is told (kept, to tell it again after a fallback) ----
  let robot: RobotInfo | null = null;
  /** While set, the view draws this instead of the live datagrams. */
  let recorded: RecordedFrame | null = null;
  let drawnSample: SimSample | null = null;
  let working: string | null = null;
  const blades = { A: { on: true, uncertain: false }, B: { on: false, uncertain: false } };
  let discs: readonly WaferDisc[] = [];
  const stations = new Map<string, StationSpec & { id: string }>();
  let obstacles: readonly ObstacleSpec[] = [];
  let width = 0;
  let height = 0;
  let disposed = false;
  const live = new LiveStream(bus, () => updateOverlay(performance.now()));

  function replay(): void {
    driver.post({ t: 'size', width, height });
    if (robot) driver.post({ t: 'robot', robot, positions: live.latest?.positions ?? null, state: live.latest?.state ?? 'IDLE' });
    driver.post({ t: 'blade', blade: 'A', ...blades.A });
    driver.post({ t: 'blade', blade: 'B', ...blades.B });
    driver.post({ t: 'stations', specs: [...stations.values()] });
    driver.post({ t: 'slots', discs: [...discs] });
    driver.post({ t: 'obstacles', list: [...obstacles] });
  }

  function cameraAsk(top: boolean, unlessMoved: boolean): CameraAsk {
    const s = live.latest;
    return { top, hand: s ? { x: s.x, y: s.y } : null, working, unlessMoved };
  }

  function setRobot(r: RobotInfo, positions: number[] | null, state: RobotState): void {
    robot = r;
    driver.post({ t: 'robot', robot: r, positions, state });
    driver.post({ t: 'camera', ask: cameraAsk(false, true) });
    updateOverlay(performance.now());
  }

  button('Top', 'View from above', () => driver.post({ t: 'camera', ask: cameraAsk(true, false) }));
  button('Reset view', 'Back to the default camera: the robot and the station it works at', () =>
    driver.post({ t: 'camera', ask: cameraAsk(false, false) }),
  );
  button('Reset counts', 'Reset the lost-datagram counters', () => {
    live.stats.reset();
    updateOverlay(performance.now());
  });

  function updateOverlay(now: number): void {
    const shown = recorded?.robot ?? robot;
    drawOverlay(overlay, {
      robot: shown ?? bus.robot(),
      drawn: shown ? { robot: shown, axes: armAxes(shown) } : null,
      connected: live.connected,
      live: recorded === null ? drawnSample : null,
      recorded,
      rateHz: live.stats.rate(now),
      lost: live.stats.lost,
      gaps: live.stats.gaps,
    });
    if (!shown) showMessage(live.connected ? 'Waiting for the robot description (ROBOT)…' : 'Not connected to the controller.');
    else showMessage(null);
  }

  // ---- the live robot: only what changes the drawing is sent ----
  const unsubSample = bus.onSample((s) => {
    if (recorded !== null || sameDrawing(drawnSample, s)) return;
    drawnSample = s;
    driver.post({ t: 'pose', positions: s.positions, state: s.state });
  });
  // The overlay's figures: four times a second while the arm moves, once a second at rest
  // (each update repaints the page: at rest that is the view's only cost).
  let lastOverlay = 0;
  let overlaySample: SimSample | null = null;
  const overlayTimer = setInterval(() => {
    if (!visible()) return;
    const now = performance.now();
    const moving = drawnSample !== overlaySample;
    if (moving || now - lastOverlay >= 1000) {
      lastOverlay = now;
      overlaySample = drawnSample;
      updateOverlay(now);
    }
  }, 250);
  const unsubRobot = bus.onRobot((r) => {
    if (recorded === null) setRobot(r, live.latest?.positions ?? null, live.latest?.state ?? 'IDLE');
  });
  const r0 = bus.robot();
  if (r0) setRobot(r0, live.latest?.positions ?? null, live.latest?.state ?? 'IDLE');

  // ---- size and visibility ----
  function visible(): boolean {
    return root.isConnected && root.offsetParent !== null && !(typeof document !== 'undefined' && document.hidden);
  }
  let wasVisible = true;
  function resize(): void {
    if (disposed) return;
    const shown = visible();
    if (shown !== wasVisible) {
      wasVisible = shown;
      driver.post({ t: 'visible', visible: shown });
    }
    const w = root.clientWidth;
    const ht = root.clientHeight;
    if (w <= 0 || ht <= 0 || (w === width && ht === height)) return;
    width = w;
    height = ht;
    driver.post({ t: 'size', width: w, height: ht });
  }
  const ro = typeof ResizeObserver !== 'undefined' ? new ResizeObserver(() => resize()) : null;
  ro?.observe(root);
  const onVisibility = (): void => resize();
  document.addEventListener('visibilitychange', onVisibility);

  // ---- the pointer: orbit (left drag), pan (right or middle drag, or Shift), zoom (wheel) ----
  function listen(c: HTMLCanvasElement): void {
    let drag: { id: number; x: number; y: number; pan: boolean } | null = null;
    c.addEventListener('pointerdown', (e) => {
      c.focus();
      drag = { id: e.pointerId, x: e.clientX, y: e.clientY, pan: e.button !== 0 || e.shiftKey };
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener('pointermove', (e) => {
      if (!drag || e.pointerId !== drag.id) return;
      const dx = e.clientX - drag.x;
      const dy = e.clientY - drag.y;
      drag.x = e.clientX;
      drag.y = e.clientY;
      if (dx !== 0 || dy !== 0) driver.post({ t: 'orbit', kind: drag.pan ? 'pan' : 'rotate', dx, dy });
    });
    const end = (e: PointerEvent): void => {
      if (drag && e.pointerId === drag.id) drag = null;
    };
    c.addEventListener('pointerup', end);
    c.addEventListener('pointercancel', end);
    c.addEventListener('contextmenu', (e) => e.preventDefault());
    c.addEventListener(
      'wheel',
      (e) => {
        e.preventDefault();
        driver.post({ t: 'orbit', kind: 'zoom', dx: 0, dy: e.deltaY * (e.deltaMode === 1 ? 40 : 1) });
      },
      { passive: false },
    );
  }
  listen(canvas);

  function showRecorded(frame: RecordedFrame | null): void {
    recorded = frame;
    if (frame !== null) {
      if (robot !== frame.robot) setRobot(frame.robot, frame.positions, frame.state ?? 'IDLE');
      driver.post({ t: 'pose', positions: frame.positions, state: frame.state ?? 'IDLE' });
    } else {
      const r = bus.robot();
      const s = live.latest;
      if (r && robot !== r) setRobot(r, s?.positions ?? null, s?.state ?? 'IDLE');
      drawnSample = s;
      if (s) driver.post({ t: 'pose', positions: s.positions, state: s.state });
    }
    updateOverlay(performance.now());
  }

  resize();
  updateOverlay(performance.now());

  function postStations(): void {
    driver.post({ t: 'stations', specs: [...stations.values()] });
    driver.post({ t: 'camera', ask: cameraAsk(false, true) });
  }

  return {
    resize() {
      width = 0; // force: the container may have been hidden at the same size
      resize();
    },
    addStation(spec) {
      let id = spec.name || 'station';
      for (let k = 2; stations.has(id); k++) id = `${spec.name}#${k}`;
      stations.set(id, { ...spec, id });
      postStations();
      return id;
    },
    removeStation(id) {
      if (stations.delete(id)) postStations();
    },
    clearStations() {
      if (stations.size === 0) return;
      stations.clear();
      postStations();
    },
    setWafer(on: boolean, uncertain = false) {
      if (on === blades.A.on && uncertain === blades.A.uncertain) return;
      blades.A = { on, uncertain };
      driver.post({ t: 'blade', blade: 'A', on, uncertain });
    },
    setBladeBWafer(on: boolean, uncertain = false) {
      if (on === blades.B.on && uncertain === blades.B.uncertain) return;
      blades.B = { on, uncertain };
      driver.post({ t: 'blade', blade: 'B', on, uncertain });
    },
    setStationWafers(d) {
      discs = d;
      driver.post({ t: 'slots', discs: [...d] });
    },
    setObstacles(list) {
      obstacles = list;
      driver.post({ t: 'obstacles', list: [...list] });
    },
    setWorkingStation(name) {
      working = name;
    },
    moveTo(target) {
      if (root.parentElement === target) return;
      target.append(root);
      width = 0;
      resize();
    },
    quality: () => quality,
    framesDrawn: () => last?.frames ?? 0,
    drawnIn: () => where,
    slotDrawCalls: () => last?.slotDrawCalls ?? 0,
    frameTimes: () => last?.frameMs ?? { lastMs: 0, maxMs: 0 },
    showRecorded,
    drawnPose: () => last?.pose ?? null,
    drawnWafers: () => ({ hand: last?.blades?.hand ?? null, bladeB: last?.blades?.bladeB ?? null, slots: { ...(last?.slots ?? {}) } }),
    dispose() {
      if (disposed) return;
      disposed = true;
      clearInterval(overlayTimer);
      unsubRobot();
      unsubSample();
      live.dispose();
      ro?.disconnect();
      document.removeEventListener('visibilitychange', onVisibility);
      driver.dispose();
      root.remove();
    },
  };
}
