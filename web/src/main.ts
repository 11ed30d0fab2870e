// The app shell: the header (robot, connection, state, error, a program's alarm, the recovery
// banner, control lock, RESET and the E-STOP), the Control panel on the left (with the Trace
// card), the tabs [Simulator (3D view and trace viewer) | Wafers | Editor | Plots] on the
// right, and the recovery panel over them when a restart left something uncertain.

import './style.css';
import { h } from './dom';
import { Commander } from './protocol/commander';
import { Connection, defaultUrl } from './protocol/connection';
import { ControllerModel } from './protocol/controller-model';
import { mountStations } from './cell/stations';
import { createWaferStore, drawWafers } from './cell/wafers';
import { createRecoveryStore } from './cell/recovery';
import { mountControl } from './panels/control-panel';
import { mountWaferPanel } from './panels/wafer-panel';
import { mountSimulator } from './view3d/simulator';
import { mountPlots } from './plots/plots';
import { mountEditor } from './editor/editor';
import { mountAlarmBanner } from './panels/alarm-banner';
import { mountRecovery } from './panels/recovery-panel';
import { traceSaveCard } from './trace/trace-save';
import { mountTraceViewer } from './trace/trace-viewer';

type TabName = 'simulator' | 'wafers' | 'editor' | 'plots';
const TAB_NAMES: readonly TabName[] = ['simulator', 'wafers', 'editor', 'plots'];

function start(): void {
  const app = document.getElementById('app') ?? document.body.appendChild(h('div', { id: 'app' }));
  const bus = new Connection(defaultUrl(window.location));
  const model = new ControllerModel(bus);
  const cmd = new Commander(bus, model);

  // ---- header ----
  const robotName = h('span', { class: 'robot-name', 'data-testid': 'robot-name' }, '');
  const conn = h('span', { class: 'conn', 'data-testid': 'connection', 'data-connected': '0' }, 'connecting…');
  const state = h('span', { class: 'state-badge big', 'data-testid': 'state', 'data-state': 'OFFLINE' }, 'OFFLINE');
  const homed = h('span', { class: 'homed', 'data-testid': 'homed', 'data-homed': '0' }, '');
  const err = h('span', { class: 'header-error', 'data-testid': 'header-error' }, '');
  const owner = h('span', { class: 'owner', 'data-testid': 'lock-owner' }, 'nobody');
  const lockBtn = h('button', {
    class: 'btn lock',
    'data-testid': 'take-control',
    onclick: () => void cmd.send(model.holdsControl() ? 'RELEASE' : 'CONTROL'),
  }, 'Take control');
  const resetBtn = h('button', {
    class: 'btn reset',
    'data-testid': 'reset',
    title: 'RESET: clear ERROR / ESTOP once the cause is gone',
    onclick: () => void cmd.send('RESET'),
  }, 'Reset');
  // Filled once the stores exist (below): the header is built first.
  const recoveryBanner = h('span', { class: 'recovery-slot' });
  const estop = h('button', {
    class: 'estop',
    'data-testid': 'estop',
    title: 'Emergency stop (ESTOP)',
    onclick: () => void cmd.send('ESTOP'),
  }, 'E-STOP');

  const header = h(
    'header',
    { class: 'app-header' },
    h('div', { class: 'brand' }, h('span', { class: 'logo' }, 'wrc'), robotName),
    conn,
    state,
    homed,
    err,
    mountAlarmBanner(bus),
    recoveryBanner,
    h('span', { class: 'spacer' }),
    h('span', { class: 'lock-label' }, 'Control: ', owner),
    lockBtn,
    resetBtn,
    estop,
  );

  // ---- body ----
  const controlEl = h('aside', { id: 'panel-control', class: 'panel' });
  const simEl = h('div', { id: 'panel-simulator', class: 'panel tab-panel sim-tab' });
  const simView = h('div', { class: 'sim-view' });
  simEl.append(simView);
  const wafersEl = h('div', { id: 'panel-wafers', class: 'panel tab-panel' });
  const editorEl = h('div', { id: 'panel-editor', class: 'panel tab-panel' });
  const plotsEl = h('div', { id: 'panel-plots', class: 'panel tab-panel' });
  const tabs: Record<TabName, { btn: HTMLButtonElement; el: HTMLElement; label: string }> = {
    simulator: { btn: h('button'), el: simEl, label: 'Simulator' },
    wafers: { btn: h('button'), el: wafersEl, label: 'Wafers' },
    editor: { btn: h('button'), el: editorEl, label: 'Editor' },
    plots: { btn: h('button'), el: plotsEl, label: 'Plots' },
  };
  const tabBar = h('nav', { class: 'tabs', role: 'tablist' });
  for (const [name, t] of Object.entries(tabs) as [TabName, (typeof tabs)[TabName]][]) {
    t.btn = h('button', { class: 'tab', role: 'tab', 'data-testid': `tab-${name}`, onclick: () => show(name) }, t.label);
    tabBar.append(t.btn);
  }
  const right = h('main', { class: 'right' }, tabBar, h('div', { class: 'tab-body' }, simEl, wafersEl, editorEl, plotsEl));
  app.replaceChildren(header, h('div', { class: 'body' }, controlEl, right));

  mountControl(controlEl, model, cmd, [traceSaveCard(model, cmd)]);
  const sim = mountSimulator(simView, bus);
  const traces = mountTraceViewer(simEl, sim, bus);
  const stations = mountStations(bus, sim);
  const wafers = createWaferStore(bus);
  drawWafers(wafers, stations, sim);
  const recoveryStore = createRecoveryStore(bus);
  const recovery = mountRecovery({ store: recoveryStore, model, cmd, wafers, stations });
  recoveryBanner.replaceWith(recovery.banner);
  app.append(recovery.panel);
  const panels: Record<TabName, { resize(): void }> = {
    simulator: sim,
    wafers: mountWaferPanel(wafersEl, wafers, model, cmd, stations),
    editor: mountEditor(editorEl, bus),
    plots: mountPlots(plotsEl, bus),
  };

  let active: TabName = 'simulator';
  function show(name: TabName): void {
    active = name;
    for (const [n, t] of Object.entries(tabs) as [TabName, (typeof tabs)[TabName]][]) {
      const on = n === name;
      t.el.hidden = !on;
      t.btn.classList.toggle('active', on);
      t.btn.setAttribute('aria-selected', on ? 'true' : 'false');
    }
    try {
      localStorage.setItem('wrc.tab', name);
    } catch {
      /* ignore */
    }
    // After layout, so the panel measures its visible size.
    requestAnimationFrame(() => panels[name].resize());
  }
  const savedTab = (() => {
    try {
      return localStorage.getItem('wrc.tab');
    } catch {
      return null;
    }
  })();
  show(TAB_NAMES.find((t) => t === savedTab) ?? 'simulator');
  window.addEventListener('resize', () => panels[active].resize());

  // ---- header updates ----
  model.onChange((v) => {
    conn.textContent = v.connected ? 'connected' : v.connDetail || 'disconnected';
    conn.title = v.connDetail;
    conn.setAttribute('data-connected', v.connected ? '1' : '0');
    const s = v.connected ? (v.state ?? '…') : 'OFFLINE';
    if (state.textContent !== s) state.textContent = s;
    state.setAttribute('data-state', s);
    homed.textContent = v.homed === null || !v.connected ? '' : v.homed ? 'homed' : 'not homed';
    homed.setAttribute('data-homed', v.homed ? '1' : '0');
    err.textContent = v.errText;
    err.hidden = v.errText === '';
    if (v.robot) robotName.textContent = v.robot.name;
    const mine = model.holdsControl();
    owner.textContent = v.owner === 'none' ? 'nobody' : mine ? `${v.owner} (this page)` : v.owner;
    owner.setAttribute('data-owner', v.owner);
    owner.setAttribute('data-mine', mine ? '1' : '0');
    lockBtn.textContent = mine ? 'Release control' : 'Take control';
    lockBtn.disabled = !v.connected || (v.owner !== 'none' && !mine);
    resetBtn.disabled = !v.connected;
    estop.disabled = false; // always pressable; a NAK/log says so when offline
    document.title = `wrc — ${v.robot?.name ?? 'robot'} — ${s}`;
  });

  window.addEventListener('beforeunload', () => bus.close());
  // For debugging from the browser console; the e2e test reads the drawn pose and wafers
  // (sim.drawnPose(), sim.drawnWafers()).
  (window as unknown as { wrc: unknown }).wrc = { bus, model, wafers, sim, traces, recovery: recoveryStore };
}

start();
