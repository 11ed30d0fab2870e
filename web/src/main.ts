// The app shell: the header (robot, connection, state, the running program, error, a
// program's alarm, the recovery banner, control lock, RESET and the E-STOP), the status line
// (refusals, alarms and stops until read), the Control panel on the left (with the Trace
// card), the tabs [Simulator (3D view and trace viewer) | Wafers (with the 3D view beside the
// map) | Editor | Plots] on the right, and the recovery panel over them when a restart left
// something uncertain.

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
import { mountHeader } from './panels/header';
import { mountStatusLine } from './panels/status-line';
import { NoticeBoard } from './protocol/notices';
import { feedNotices } from './protocol/notice-feed';
import { ProgramTracker } from './protocol/program-tracker';
import { TabPeers } from './protocol/tabs';
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
  const board = new NoticeBoard();
  feedNotices(board, bus, cmd);
  const program = new ProgramTracker(bus);
  const peers = new TabPeers();

  // ---- header and status line ----
  // Filled once the stores exist (below): the header is built first.
  const recoveryBanner = h('span', { class: 'recovery-slot' });
  const header = mountHeader({ model, cmd, board, program, tabs: peers, banners: [mountAlarmBanner(bus), recoveryBanner] });
  const statusLine = mountStatusLine(board);

  // ---- body ----
  const controlEl = h('aside', { id: 'panel-control', class: 'panel' });
  const simEl = h('div', { id: 'panel-simulator', class: 'panel tab-panel sim-tab' });
  const simView = h('div', { class: 'sim-view' });
  simEl.append(simView);
  // The Wafers tab: the map, and the 3D view beside it (moved there while the tab is shown).
  const wafersMain = h('div', { class: 'wafers-main' });
  const wafersSide = h('div', { class: 'wafers-side', 'data-testid': 'wafers-3d' });
  const wafersEl = h('div', { id: 'panel-wafers', class: 'panel tab-panel wafers-split' }, wafersMain, wafersSide);
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
  app.replaceChildren(header, statusLine, h('div', { class: 'body' }, controlEl, right));

  const sim = mountSimulator(simView, bus);
  const traces = mountTraceViewer(simEl, sim, bus);
  const stations = mountStations(bus, sim);
  const wafers = createWaferStore(bus);
  drawWafers(wafers, stations, sim);
  mountControl(controlEl, { model, cmd, program, peers, wafers }, [traceSaveCard(model, cmd)]);
  const recoveryStore = createRecoveryStore(bus);
  const recovery = mountRecovery({ store: recoveryStore, model, cmd, wafers, stations });
  recoveryBanner.replaceWith(recovery.banner);
  app.append(recovery.panel);
  const panels: Record<TabName, { resize(): void }> = {
    simulator: sim,
    wafers: mountWaferPanel(wafersMain, wafers, model, cmd, stations, program),
    editor: mountEditor(editorEl, { bus, model, program }),
    plots: mountPlots(plotsEl, bus),
  };

  let active: TabName = 'simulator';
  function show(name: TabName): void {
    active = name;
    // One 3D view, drawn where it is seen: the Simulator tab, or beside the wafer map.
    sim.moveTo(name === 'wafers' ? wafersSide : simView);
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

  window.addEventListener('beforeunload', () => {
    peers.close();
    bus.close();
  });
  // For debugging from the browser console; the e2e test reads the drawn pose and wafers
  // (sim.drawnPose(), sim.drawnWafers()).
  (window as unknown as { wrc: unknown }).wrc = { bus, model, wafers, sim, traces, recovery: recoveryStore, notices: board, program };
}

start();
