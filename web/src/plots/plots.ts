// Plots panel: (1) output pulses per period of each axis (uPlot; the paper's Fig. 7 and 8)
// from the simulator datagrams, on the controller's clock (the datagram's timestamp): the last
// `HISTORY_S` seconds are kept whatever tab is shown, and the chart is a window over them that
// follows the newest point or is scrolled back (a move made while another tab was shown is
// still there); redrawn only when visible and changed; (2) the live task timing table (the paper's Tables 3 and
// 4) from `TASKS`, polled every second while the panel is visible and the bus connected,
// with each task's wake-up latency histogram as a small log-scale bar chart.

import { h } from '../dom';
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';
import type { Bus, RobotInfo, SimSample, TaskTiming } from '../protocol/bus';
import { PulseRate } from '../protocol/stream';
import { parseTasks } from './tasks';
import {
  RollingSeries,
  viewRange,
  binLabel,
  fmtCount,
  fmtMs,
  fmtUs,
  fullBins,
  logHeight,
  maxBinIndex,
} from './plot-data';
import './plots.css';

/** Series colours (up to 16 axes; repeats beyond). */
const COLORS = [
  '#4fc3f7', '#ffb74d', '#81c784', '#f06292', '#ba68c8', '#fff176', '#4db6ac', '#e57373',
  '#9575cd', '#aed581', '#64b5f6', '#ff8a65', '#dce775', '#a1887f', '#90a4ae', '#f48fb1',
];

const POLL_MS = 1000;
const WINDOWS_S = [5, 10, 30, 60, 300];
/** The history kept [s]: the last five minutes. */
export const HISTORY_S = 300;
/** The chart is redrawn at most this often while the data change [ms]. */
const REDRAW_MS = 100;


export interface PlotsHandle {
  /** Call when the panel is shown or its size changed. */
  resize(): void;
  /** Stop polling and remove the panel (not needed by the app; for tests and reuse). */
  dispose(): void;
}

export function mountPlots(root: HTMLElement, bus: Bus): PlotsHandle {
  const box = root.appendChild(h('div', { class: 'plot-root' }));
  const visible = (): boolean =>
    root.isConnected && box.offsetParent !== null && !(typeof document !== 'undefined' && document.hidden);

  const chart = mountPulseChart(box, bus, visible);
  const tasks = mountTaskTable(box, bus, visible);
  return {
    resize() {
      chart.resize();
      tasks.shown();
    },
    dispose() {
      chart.dispose();
      tasks.dispose();
      box.remove();
    },
  };
}

// ---------------------------------------------------------------------------------------------
// Pulses per period chart

function mountPulseChart(
  parent: HTMLElement,
  bus: Bus,
  visible: () => boolean,
): { resize(): void; dispose(): void } {
  const section = parent.appendChild(h('div', { class: 'plot-section plot-chart-section' }));
  const bar = section.appendChild(h('div', { class: 'plot-bar' }));
  const title = bar.appendChild(h('span', { class: 'plot-title' }, 'Output pulses per period'));
  const lostNote = bar.appendChild(h('span', { class: 'plot-note' }));
  bar.appendChild(h('span', { class: 'plot-note' }, 'window'));
  const windowSel = bar.appendChild(h('select'));
  windowSel.title = 'Time window of the chart';
  for (const w of WINDOWS_S) {
    const o = windowSel.appendChild(h('option', {}, `${w} s`));
    o.value = String(w);
  }
  windowSel.value = '10';
  const pauseBtn = bar.appendChild(h('button', {}, 'Pause'));
  pauseBtn.type = 'button';
  pauseBtn.title = 'Freeze the chart (data keeps being collected); drag to zoom while paused';
  const clearBtn = bar.appendChild(h('button', {}, 'Clear'));
  clearBtn.type = 'button';
  clearBtn.title = 'Forget the data kept';
  const area = section.appendChild(h('div', { class: 'plot-chart' }));
  // The window's place in the history: at the right end it follows the newest point.
  const scroll = section.appendChild(
    h('input', {
      type: 'range',
      class: 'plot-scroll',
      min: '0',
      max: '1000',
      step: '1',
      value: '1000',
      'data-testid': 'plot-scroll',
      'aria-label': 'Where the window is in the last minutes kept',
      title: `The window over the last ${HISTORY_S / 60} minutes kept (right: follow the newest)`,
    }),
  );
  const span = bar.appendChild(h('span', { class: 'plot-note', 'data-testid': 'plot-span' }));
  const empty = area.appendChild(h('div', { class: 'plot-empty' }, 'Waiting for simulator datagrams…'));

  let windowS = 10;
  let paused = false;
  let names: string[] = [];
  let series = new RollingSeries(0, HISTORY_S);
  /** Where the window ends [s of the chart's time]; null: at the newest point. */
  let end: number | null = null;
  const rate = new PulseRate(0);
  let t0: number | null = null;
  let lost = 0;
  let u: uPlot | null = null;
  let changed = false;
  let disposed = false;

  const axisNames = (robot: RobotInfo | null, n: number): string[] => {
    const out: string[] = [];
    for (let i = 0; i < n; i++) {
      const a = robot?.axes.find((x) => x.index === i + 1) ?? robot?.axes[i];
      out.push(a ? a.name : `axis ${i + 1}`);
    }
    return out;
  };

  function updateTitle(): void {
    const r = bus.robot();
    title.textContent =
      r && r.periodMs > 0
        ? `Output pulses per period (${fmtMs(r.periodMs)} ms)`
        : 'Output pulses per period';
    lostNote.textContent = lost > 0 ? `${lost} datagram${lost === 1 ? '' : 's'} lost` : '';
    lostNote.className = lost > 0 ? 'plot-warn' : 'plot-note';
  }

  function chartSize(): { width: number; height: number } | null {
    const w = area.clientWidth;
    const ht = area.clientHeight;
    if (w < 50 || ht < 60) return null;
    const legend = u?.root.querySelector('.u-legend') as HTMLElement | null;
    const lh = legend ? legend.offsetHeight : 24 + 16 * Math.ceil(names.length / 6);
    return { width: w, height: Math.max(60, ht - lh - 4) };
  }

  function destroyChart(): void {
    u?.destroy();
    u = null;
  }

  function createChart(): void {
    destroyChart();
    const size = chartSize();
    if (!size || names.length === 0) return;
    const axisStyle = {
      stroke: '#8b96a3',
      grid: { stroke: '#262c33', width: 1 },
      ticks: { stroke: '#30373f', width: 1 },
      font: '11px ui-monospace, monospace',
      labelFont: '11px ui-monospace, monospace',
    };
    const opts: uPlot.Options = {
      width: size.width,
      height: size.height,
      scales: {
        x: {
          time: false,
          range: () => viewRange(series.first(), series.last(), windowS, end),
        },
        y: {
          range: (_u, min, max) => {
            // Symmetric about 0 is easier to read for motions in both directions; never a
            // zero-height range when every axis stands still.
            const m = Math.max(Math.abs(min), Math.abs(max), 1) * 1.1;
            return [min < 0 ? -m : Math.min(0, min), max > 0 ? m : Math.max(0, max) || m];
          },
        },
      },
      series: [
        { label: 't [s]', value: (_u, v) => (v === null ? '—' : v.toFixed(2)) },
        ...names.map((name, i) => ({
          label: name,
          stroke: COLORS[i % COLORS.length],
          width: 1.5,
          points: { show: false },
          spanGaps: false,
          value: (_u: uPlot, v: number | null) => (v === null ? '—' : v.toFixed(1)),
        })),
      ],
      axes: [
        { ...axisStyle, label: "controller's clock [s]", labelSize: 18 },
        { ...axisStyle, label: 'pulses / period', labelSize: 18, size: 60 },
      ],
      cursor: { drag: { x: true, y: false } },
      legend: { live: true },
    };
    u = new uPlot(opts, visibleData(), area);
    const s2 = chartSize();
    if (s2) u.setSize(s2);
    changed = true;
  }

  /** The points of the window, and a little beyond. */
  function visibleData(): ReturnType<RollingSeries['data']> {
    const [a, b] = viewRange(series.first(), series.last(), windowS, end);
    return series.range(a, b);
  }

  function reset(n: number): void {
    names = axisNames(bus.robot(), n);
    series = new RollingSeries(n, HISTORY_S);
    rate.reset();
    t0 = null;
    createChart();
  }

  function clear(): void {
    series.clear();
    rate.reset();
    t0 = null;
    lost = 0;
    end = null;
    scroll.value = '1000';
    changed = true;
    // Cleared even while paused.
    if (paused) u?.setData(visibleData(), true);
    updateTitle();
    schedule();
  }

  function onSample(s: SimSample): void {
    if (s.pulses.length !== series.nSeries) reset(s.pulses.length);
    const p = rate.push(s);
    if (t0 === null) t0 = s.timeNs;
    if (!p) return;
    if (p.lost > 0) {
      lost += p.lost;
      updateTitle();
    }
    const t = (p.timeNs - t0) / 1e9;
    if (t < 0) {
      // The controller's clock restarted: start the chart again.
      clear();
      t0 = s.timeNs;
      return;
    }
    series.push(t, p.perPeriod);
    changed = true;
    schedule();
  }

  pauseBtn.addEventListener('click', () => {
    paused = !paused;
    pauseBtn.textContent = paused ? 'Resume' : 'Pause';
    pauseBtn.classList.toggle('plot-on', paused);
    changed = true;
    schedule();
  });
  scroll.addEventListener('input', () => {
    const v = Number(scroll.value);
    const first = series.first();
    const last = series.last();
    end = v >= 1000 || first === null || last === null ? null : first + ((last - first) * v) / 1000;
    changed = true;
    schedule();
  });
  clearBtn.addEventListener('click', () => clear());
  windowSel.addEventListener('change', () => {
    windowS = Number(windowSel.value) || 10;
    changed = true;
    schedule();
  });

  const onRobot = (r: RobotInfo): void => {
    rate.periodMs = r.periodMs;
    updateTitle();
    const n = series.nSeries || r.axes.length;
    const newNames = axisNames(r, n);
    if (newNames.join('\u0000') !== names.join('\u0000') || n !== series.nSeries) reset(n);
  };
  const unsubs = [bus.onSample(onSample), bus.onRobot(onRobot)];
  const r0 = bus.robot();
  if (r0) onRobot(r0);

  // Follow the area's size (window resizes, the table growing); resize() covers the rest.
  let lastW = 0;
  let lastH = 0;
  const ro =
    typeof ResizeObserver !== 'undefined'
      ? new ResizeObserver(() => {
          if (area.clientWidth === lastW && area.clientHeight === lastH) return;
          lastW = area.clientWidth;
          lastH = area.clientHeight;
          if (!u) createChart();
          else {
            const s = chartSize();
            if (s) u.setSize(s);
          }
        })
      : null;
  ro?.observe(area);

  // Drawn on demand: a frame is asked for when the data or the view changed, and drawn only
  // while the panel is visible (shown again, resize() draws it), at most every REDRAW_MS.
  let raf = 0;
  let lastDraw = -Infinity;
  function schedule(): void {
    if (raf !== 0 || disposed || !visible()) return;
    raf = requestAnimationFrame(frame);
  }
  function frame(now: number): void {
    raf = 0;
    if (disposed || !visible()) return;
    if (now - lastDraw < REDRAW_MS) {
      schedule();
      return;
    }
    if (!u && names.length > 0) createChart();
    empty.style.display = series.length > 0 ? 'none' : '';
    const first = series.first();
    const last = series.last();
    span.textContent = first !== null && last !== null ? `kept ${(last - first).toFixed(0)} s of ${HISTORY_S} s${end === null ? '' : ' · scrolled back'}` : '';
    if (!u || paused || !changed) return;
    changed = false;
    lastDraw = now;
    u.setData(visibleData(), true);
  }
  updateTitle();

  return {
    resize() {
      changed = true;
      schedule();
      if (!u) {
        createChart();
        return;
      }
      const s = chartSize();
      if (s) u.setSize(s);
    },
    dispose() {
      disposed = true;
      cancelAnimationFrame(raf);
      ro?.disconnect();
      for (const f of unsubs) f();
      destroyChart();
    },
  };
}

// ---------------------------------------------------------------------------------------------
// Task timing table

const HIST_W = 150;
const HIST_H = 30;

function mountTaskTable(
  parent: HTMLElement,
  bus: Bus,
  visible: () => boolean,
): { shown(): void; dispose(): void } {
  const section = parent.appendChild(h('div', { class: 'plot-section plot-tasks-section' }));
  const bar = section.appendChild(h('div', { class: 'plot-bar' }));
  bar.appendChild(h('span', { class: 'plot-title' }, 'Real-time tasks'));
  const status = bar.appendChild(h('span', { class: 'plot-note' }));
  const wrap = section.appendChild(h('div', { class: 'plot-table-wrap' }));
  const table = wrap.appendChild(h('table', { class: 'plot-table' }));
  const thead = table.appendChild(h('thead'));
  const h1 = thead.appendChild(h('tr'));
  const h2 = thead.appendChild(h('tr'));
  const th = (row: HTMLElement, text: string, opts: { rows?: number; cols?: number; title?: string } = {}): void => {
    const c = row.appendChild(h('th', {}, text));
    if (opts.rows) c.rowSpan = opts.rows;
    if (opts.cols) c.colSpan = opts.cols;
    if (opts.title) c.title = opts.title;
  };
  th(h1, 'Task', { rows: 2 });
  th(h1, 'Prio', { rows: 2, title: 'Configured priority (lower = more urgent)' });
  th(h1, 'Period [ms]', { rows: 2, title: 'Configured period' });
  th(h1, 'Measured period [µs]', { cols: 3 });
  th(h1, 'Execution [µs]', { cols: 2 });
  th(h1, 'Wake-up latency [µs]', { cols: 3 });
  th(h1, 'Overruns', { rows: 2, title: 'Cycles longer than the period' });
  th(h1, 'Missed', { rows: 2, title: 'Missed periods' });
  th(h1, 'Cycles', { rows: 2 });
  th(h1, 'Latency histogram', { rows: 2, title: 'Cycles per power-of-two latency bin, log scale' });
  for (const t of ['avg', 'min', 'max', 'avg', 'max', 'avg', 'p99', 'max']) th(h2, t);
  const tbody = table.appendChild(h('tbody'));

  interface Row {
    name: string;
    cells: HTMLTableCellElement[];
    canvas: HTMLCanvasElement;
  }
  let rows: Row[] = [];
  let timer: ReturnType<typeof setInterval> | null = null;
  let inflight = 0; // time the pending request was sent (0: none)
  let token = 0;
  let disposed = false;

  function setStatus(text: string, cls = 'plot-note'): void {
    status.textContent = text;
    status.className = cls;
  }

  function buildRows(tasks: TaskTiming[]): void {
    tbody.replaceChildren();
    rows = tasks.map((t) => {
      const tr = tbody.appendChild(h('tr'));
      const cells: HTMLTableCellElement[] = [];
      for (let i = 0; i < 14; i++) cells.push(tr.appendChild(h('td', { class: i === 0 ? 'plot-name' : undefined })));
      const hc = tr.appendChild(h('td', { class: 'plot-hist' }));
      const canvas = hc.appendChild(h('canvas'));
      const dpr = Math.min(typeof window !== 'undefined' ? window.devicePixelRatio || 1 : 1, 3);
      canvas.width = Math.round(HIST_W * dpr);
      canvas.height = Math.round(HIST_H * dpr);
      canvas.style.width = `${HIST_W}px`;
      canvas.style.height = `${HIST_H}px`;
      return { name: t.name, cells, canvas };
    });
  }

  function render(tasks: TaskTiming[]): void {
    if (rows.length !== tasks.length || rows.some((r, i) => r.name !== tasks[i]?.name)) buildRows(tasks);
    const maxIdx = maxBinIndex(tasks);
    tasks.forEach((t, i) => {
      const row = rows[i] as Row;
      const values: [string, string][] = [
        [t.name, ''],
        [String(t.priority), ''],
        [fmtMs(t.periodMs), ''],
        [fmtUs(t.periodAvgUs), ''],
        [fmtUs(t.periodMinUs), ''],
        [fmtUs(t.periodMaxUs), ''],
        [fmtUs(t.execAvgUs), ''],
        [fmtUs(t.execMaxUs), ''],
        [fmtUs(t.latAvgUs), ''],
        [fmtUs(t.latP99Us), ''],
        [fmtUs(t.latMaxUs), ''],
        [fmtCount(t.overruns), t.overruns > 0 ? 'plot-bad' : ''],
        [fmtCount(t.missed), t.missed > 0 ? 'plot-bad' : ''],
        [fmtCount(t.cycles), ''],
      ];
      values.forEach(([text, cls], k) => {
        const c = row.cells[k] as HTMLTableCellElement;
        if (c.textContent !== text) c.textContent = text;
        const want = k === 0 ? 'plot-name' : cls;
        if (c.className !== want) c.className = want;
      });
      drawHistogram(row.canvas, t, maxIdx);
    });
  }

  async function poll(): Promise<void> {
    if (disposed || !visible() || !bus.connected()) return;
    const now = Date.now();
    // A request that has not been answered in 5 s is given up (the connection was lost).
    if (inflight !== 0 && now - inflight < 5000) return;
    inflight = now;
    const mine = ++token;
    try {
      const { first, events } = await bus.request('TASKS');
      if (mine !== token || disposed) return;
      if (first.kind === 'NAK') {
        setStatus(`TASKS refused: ${first.code} ${first.text}`, 'plot-warn');
        return;
      }
      const tasks = parseTasks(events);
      render(tasks);
      setStatus(`${tasks.length} task${tasks.length === 1 ? '' : 's'} · updated ${new Date().toLocaleTimeString()}`);
    } catch (e) {
      if (mine === token) setStatus(`TASKS failed: ${e instanceof Error ? e.message : String(e)}`, 'plot-warn');
    } finally {
      if (mine === token) inflight = 0;
    }
  }

  timer = setInterval(() => void poll(), POLL_MS);
  const unsub = bus.onConnection((c) => {
    if (c) void poll();
    else setStatus('not connected', 'plot-warn');
  });
  if (!bus.connected()) setStatus('not connected', 'plot-warn');
  void poll();

  return {
    shown() {
      void poll();
      for (const r of rows) r.canvas.style.width = `${HIST_W}px`;
    },
    dispose() {
      disposed = true;
      if (timer !== null) clearInterval(timer);
      unsub();
    },
  };
}

/** A task's latency histogram: one bar per power-of-two bin, height on a log scale. */
function drawHistogram(canvas: HTMLCanvasElement, t: TaskTiming, maxIdx: number): void {
  const ctx = canvas.getContext('2d');
  const bins = fullBins(t.latHist, maxIdx);
  canvas.title = bins
    .filter((b) => b.count > 0)
    .map((b) => `${binLabel(b.upperUs)}: ${b.count}`)
    .join('\n') || 'no cycles yet';
  if (!ctx) return;
  const W = canvas.width;
  const H = canvas.height;
  const s = W / HIST_W;
  ctx.clearRect(0, 0, W, H);
  const labelH = 9 * s;
  const plotH = H - labelH - 1 * s;
  const n = bins.length;
  const bw = W / n;
  const maxCount = bins.reduce((m, b) => Math.max(m, b.count), 0);
  ctx.fillStyle = '#20262d';
  ctx.fillRect(0, 0, W, plotH);
  for (let k = 0; k < n; k++) {
    const b = bins[k] as { upperUs: number; count: number };
    const barH = logHeight(b.count, maxCount) * (plotH - 1 * s);
    if (barH <= 0) continue;
    // 1 ms and beyond in red, 128 µs and beyond in amber: latencies a 10 ms cycle notices.
    ctx.fillStyle = b.upperUs > 1024 ? '#ff6a5e' : b.upperUs > 128 ? '#f0b23c' : '#4fc3a1';
    ctx.fillRect(k * bw + 0.5 * s, plotH - barH, Math.max(1, bw - 1 * s), barH);
  }
  ctx.fillStyle = '#7d8894';
  ctx.font = `${8 * s}px ui-monospace, monospace`;
  ctx.textBaseline = 'bottom';
  ctx.textAlign = 'left';
  ctx.fillText('1', 0, H);
  ctx.textAlign = 'right';
  const top = 2 ** maxIdx;
  ctx.fillText(`${top} µs`, W, H);
}
