// Simulator panel (the paper's Fig. 5): a three.js view of the robot built from `ROBOT`
// (bus.robot / bus.onRobot) and animated from the simulator datagrams (bus.onSample), or, while
// the trace viewer has a trace open, the recorded robot at its scrubber (showRecorded).
//
// This module wires the parts together and runs the animation loop: the scene (scene.ts) with
// the drawn robot (robot-model.ts), the live datagrams (live-stream.ts) and the text overlay
// (overlay.ts).

import * as THREE from 'three';
import type { Bus, RobotInfo, RobotState } from '../protocol/bus';
import { h, injectStyle } from '../dom';
import { LiveStream } from './live-stream';
import { drawOverlay } from './overlay';
import { SimScene, type StationSpec, type WaferDisc } from './scene';
import { armPose, homePositions, type ArmPose } from './sim-kinematics';

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
    const c = h('canvas');
    const gl = c.getContext('webgl2');
    // Give the probe's context back at once: browsers allow only a few at a time.
    gl?.getExtension('WEBGL_lose_context')?.loseContext();
    return gl !== null;
  } catch {
    return false;
  }
}

export function mountSimulator(el: HTMLElement, bus: Bus): SimulatorHandle {
  injectStyle(STYLE_ID, STYLE);
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
    showRecorded() {},
    drawnPose: () => null,
    drawnWafers: () => ({ hand: null, bladeB: null, slots: {} }),
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
  const view = new SimScene(renderer);
  root.insertBefore(renderer.domElement, msg);

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
  const live = new LiveStream(bus, () => updateOverlay(performance.now()));

  function applyState(s: RobotState): void {
    state = s;
    view.materials.tint(s);
  }

  function setRobot(robot: RobotInfo): void {
    const first = view.robot === null;
    const model = view.setRobot(robot, { hand: waferOnHand, bladeB: waferOnBladeB, handUncertain, bladeBUncertain });
    model.pose(armPose(model.axes, live.applied?.positions ?? live.latest?.positions ?? homePositions(robot)));
    if (first) view.fitCamera(model.reach);
    view.dirty = true;
    updateOverlay(performance.now());
  }

  button('Top', 'View from above', () => view.fitCamera(view.robot?.reach ?? 600, true));
  button('Reset view', 'Back to the default camera', () => view.fitCamera(view.robot?.reach ?? 600));
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
    view.dirty = true;
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
    if (!view.sized()) resize();
    const s = recorded === null ? live.takeNew() : null;
    if (s !== null) {
      view.robot?.pose(armPose(view.robot.axes, s.positions));
      if (s.state !== state) applyState(s.state);
      view.dirty = true;
    }
    view.updateControls();
    if (now - lastOverlay > 250) {
      lastOverlay = now;
      updateOverlay(now);
    }
    if (!contextLost) view.render();
  }
  raf = requestAnimationFrame(frame);

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
      const model = view.robot;
      if (model) model.pose(armPose(model.axes, live.latest?.positions ?? homePositions(model.robot)));
      applyState(live.latest?.state ?? 'IDLE');
    }
    view.dirty = true;
    updateOverlay(performance.now());
  }

  resize();
  updateOverlay(performance.now());

  return {
    resize() {
      view.forgetSize(); // force: the container may have been hidden at the same size
      resize();
      view.dirty = true;
    },
    addStation: (spec) => view.addStation(spec),
    removeStation: (id) => view.removeStation(id),
    clearStations: () => view.clearStations(),
    setWafer(onHand: boolean, uncertain = false) {
      if (onHand === waferOnHand && uncertain === handUncertain) return;
      waferOnHand = onHand;
      handUncertain = uncertain;
      view.robot?.showWafer(onHand, uncertain);
      view.dirty = true;
    },
    setBladeBWafer(onBladeB: boolean, uncertain = false) {
      if (onBladeB === waferOnBladeB && uncertain === bladeBUncertain) return;
      waferOnBladeB = onBladeB;
      bladeBUncertain = uncertain;
      view.robot?.showBladeBWafer(onBladeB, uncertain);
      view.dirty = true;
    },
    setStationWafers: (discs) => view.setStationWafers(discs),
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
      live.dispose();
      ro?.disconnect();
      view.dispose();
      root.remove();
    },
  };
}
