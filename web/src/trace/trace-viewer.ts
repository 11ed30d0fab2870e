// The trace viewer, a bar under the 3D view: **Open trace…** reads a `.wrctrace` file in the
// browser (trace.ts; nothing is sent anywhere), then a scrubber with play/pause and the time
// [s] runs over its samples. While a trace is open the 3D view draws the recorded robot at the
// scrubber (encoder pulses / pulses_per_unit, trace-robot.ts) instead of the live one, and
// the bar shows the state, the I/O words and the messages within ±1 s of it (requests,
// replies and events, clients connecting and connections closing);
// **Close trace** returns the view to the live robot.

import type { Bus } from '../protocol/bus';
import { parseState } from '../protocol/protocol';
import type { SimulatorHandle } from '../view3d/simulator';
import { h } from '../dom';
import { byTime, describeMessage, hex32, messagesNear, readTrace, sourceName, type Trace, type TraceMessage } from './trace';
import { positionsAt, traceRobot, type TraceRobot } from './trace-robot';
import './trace-viewer.css';

/** Messages within this much of the scrubber are listed [ns]. */
const MESSAGE_WINDOW_NS = 1e9;
/** At most this many of them are drawn, around the current one. */
const MAX_MESSAGE_ROWS = 40;


/** `1.234 s`. */
function seconds(ns: number): string {
  return `${(ns / 1e9).toFixed(3)} s`;
}

/** `+0.120 s` / `−0.005 s` from the scrubber. */
function offset(ns: number): string {
  const s = (Math.abs(ns) / 1e9).toFixed(3);
  return `${ns < 0 ? '−' : '+'}${s} s`;
}

/** An open trace and what is derived from it once. */
interface Open {
  name: string;
  trace: Trace;
  /** The messages in time order. */
  messages: TraceMessage[];
  /** The robot the 3D view draws it with; null when there is none (the view stays live). */
  robot: TraceRobot | null;
  /** Index of the sample shown. */
  index: number;
}

export interface TraceViewer {
  /** Open a trace file's bytes as if chosen with Open trace (tests, drag and drop). */
  openBytes(name: string, bytes: ArrayBuffer | Uint8Array): void;
  close(): void;
}

/** Mount the trace bar at the end of `el` (the Simulator tab), drawing into `sim`. */
export function mountTraceViewer(el: HTMLElement, sim: SimulatorHandle, bus: Pick<Bus, 'robot'>): TraceViewer {

  const input = h('input', {
    type: 'file',
    accept: '.wrctrace',
    class: 'trace-open-input',
    id: 'trace-open-input',
    'data-testid': 'trace-open',
    'aria-label': 'Open a trace file (.wrctrace)',
  });
  const openLabel = h(
    'label',
    { class: 'btn small trace-open', for: 'trace-open-input', title: 'Read a .wrctrace file saved by the controller and scrub through it' },
    'Open trace…',
  );
  const fileInfo = h('span', { class: 'trace-file', 'data-testid': 'trace-file' }, 'No trace open: the view shows the live robot.');
  const closeBtn = h('button', { class: 'btn small', 'data-testid': 'trace-close', hidden: true, onclick: () => close() }, 'Close trace');
  const error = h('div', { class: 'trace-error', 'data-testid': 'trace-error', role: 'alert' });
  const note = h('div', { class: 'trace-note', 'data-testid': 'trace-note' });

  const play = h('button', { class: 'btn small trace-play', 'data-testid': 'trace-play', 'data-playing': '0', onclick: () => toggle() }, 'Play');
  const scrubber = h('input', {
    type: 'range',
    class: 'trace-scrubber',
    min: '0',
    max: '0',
    step: '1',
    value: '0',
    'data-testid': 'trace-scrubber',
    'aria-label': 'Trace position',
  });
  const time = h('span', { class: 'trace-time', 'data-testid': 'trace-time' }, '');
  const stateEl = h('span', { class: 'state-badge', 'data-testid': 'trace-state', 'data-state': '' }, '—');
  const errEl = h('span', { 'data-testid': 'trace-err' }, '—');
  const inputsEl = h('span', { 'data-testid': 'trace-inputs' }, '—');
  const outputsEl = h('span', { 'data-testid': 'trace-outputs' }, '—');
  const list = h('div', { class: 'trace-messages', 'data-testid': 'trace-messages' });
  const player = h(
    'div',
    { class: 'trace-player', hidden: true },
    h('div', { class: 'trace-row' }, play, scrubber, time),
    h(
      'div',
      { class: 'trace-detail' },
      h(
        'div',
        { class: 'trace-readout' },
        h('span', { class: 'k' }, 'State'),
        h('span', {}, stateEl),
        h('span', { class: 'k' }, 'Error'),
        errEl,
        h('span', { class: 'k' }, 'Inputs'),
        inputsEl,
        h('span', { class: 'k' }, 'Outputs'),
        outputsEl,
      ),
      list,
    ),
  );
  const bar = h(
    'div',
    { class: 'trace-bar', 'data-testid': 'trace-bar', 'data-open': '0' },
    h('div', { class: 'trace-row' }, input, openLabel, fileInfo, closeBtn),
    error,
    note,
    player,
  );
  el.append(bar);

  let open: Open | null = null;
  let playing = false;
  let raf = 0;
  /** Trace time of the playback [ns], and the page time it was last advanced at [ms]. */
  let playT = 0;
  let lastFrame = 0;
  let listKey = '';

  input.addEventListener('change', () => {
    const file = input.files?.[0];
    // Choosing the same file again must fire `change` again.
    input.value = '';
    if (file) void openFile(file);
  });
  scrubber.addEventListener('input', () => {
    if (!open) return;
    show(Number(scrubber.value));
    playT = open.trace.samples.tNs[open.index] ?? 0;
  });

  async function openFile(file: File): Promise<void> {
    try {
      openBytes(file.name, await file.arrayBuffer());
    } catch (e) {
      // The browser could not read the file (readTrace itself never throws).
      close();
      error.textContent = `cannot read ${file.name}: ${e instanceof Error ? e.message : String(e)}`;
    }
  }

  function openBytes(name: string, bytes: ArrayBuffer | Uint8Array): void {
    close();
    const r = readTrace(bytes, name);
    if (!r.ok) {
      error.textContent = r.error.message;
      bar.setAttribute('data-error', r.error.kind);
      return;
    }
    const trace = r.trace;
    const samples = trace.samples;
    const drawn = traceRobot(trace.meta, bus.robot());
    open = { name, trace, messages: byTime(trace.messages), robot: drawn.ok ? drawn.value : null, index: 0 };
    const notes: string[] = [];
    if (!drawn.ok) notes.push(`the 3D view stays live: ${drawn.reason}`);
    else if (drawn.value.note) notes.push(drawn.value.note);
    if (samples.count === 0) notes.push('the trace holds no samples');
    note.textContent = notes.join('; ');

    const span = samples.count > 0 ? (samples.tNs[samples.count - 1] ?? 0) - (samples.tNs[0] ?? 0) : 0;
    fileInfo.replaceChildren(
      h('b', {}, name),
      ` — ${trace.meta.reason || 'no reason given'}; ${samples.count} samples over ${seconds(span)}, ` +
        `${trace.messages.length} messages; ${samples.axes} axes (${trace.meta.axisNames.join(', ')}); ` +
        `wrc ${trace.meta.wrcVersion || '?'}, ${trace.meta.clock} clock`,
    );
    fileInfo.title = fileInfo.textContent ?? '';
    closeBtn.hidden = false;
    bar.setAttribute('data-open', '1');
    player.hidden = samples.count === 0;
    scrubber.max = String(Math.max(0, samples.count - 1));
    if (samples.count > 0) show(0);
  }

  /** Show sample `i`: the readouts, the messages near it and the 3D view. */
  function show(i: number): void {
    if (!open) return;
    const { trace, robot } = open;
    const samples = trace.samples;
    const k = Math.max(0, Math.min(samples.count - 1, Math.round(i)));
    open.index = k;
    if (scrubber.value !== String(k)) scrubber.value = String(k);
    const s = samples.at(k);
    const t0 = samples.tNs[0] ?? 0;
    const tEnd = samples.tNs[samples.count - 1] ?? 0;
    time.textContent = `${seconds(s.tNs - t0)} / ${seconds(tEnd - t0)}`;
    time.title = `controller clock ${seconds(s.tNs)} (sample ${k + 1} of ${samples.count})`;
    const stateName = trace.meta.stateNames[s.state] ?? `state ${s.state}`;
    stateEl.textContent = stateName;
    stateEl.setAttribute('data-state', stateName);
    errEl.textContent = s.errorCode === 0 ? 'none' : String(s.errorCode);
    inputsEl.textContent = hex32(s.inputs);
    outputsEl.textContent = hex32(s.outputs);
    drawMessages(s.tNs);
    if (robot) {
      sim.showRecorded({
        robot: robot.robot,
        positions: positionsAt(robot, samples, k),
        state: parseState(stateName),
        label: `${open.name} at ${seconds(s.tNs - t0)}`,
      });
    }
  }

  function drawMessages(tNs: number): void {
    if (!open) return;
    const sorted = open.messages;
    const near = messagesNear(sorted, tNs, MESSAGE_WINDOW_NS);
    let from = near.from;
    let to = near.to;
    if (to - from > MAX_MESSAGE_ROWS) {
      const centre = near.current ?? from;
      from = Math.max(near.from, Math.min(centre - MAX_MESSAGE_ROWS / 2, to - MAX_MESSAGE_ROWS));
      to = from + MAX_MESSAGE_ROWS;
    }
    // The offsets change with the scrubber even when the rows do not.
    const key = `${from}:${to}:${near.current}:${tNs}`;
    if (key === listKey) return;
    listKey = key;
    if (from === to) {
      list.replaceChildren(h('div', { class: 'none' }, 'no messages within ±1 s'));
      return;
    }
    let current: HTMLElement | null = null;
    const rows: HTMLElement[] = [];
    for (let m = from; m < to; m++) {
      const msg = sorted[m] as TraceMessage;
      const isCurrent = m === near.current;
      const shown = describeMessage(msg);
      const row = h(
        'div',
        {
          class: `trace-message ${msg.direction}${isCurrent ? ' current' : ''}`,
          'data-testid': 'trace-message',
          'data-direction': msg.direction,
          'data-current': isCurrent ? '1' : '0',
          title: shown.title,
        },
        h('span', { class: 'dt' }, offset(msg.tNs - tNs)),
        h('span', { class: 'src' }, `${shown.arrow} ${sourceName(msg.source)}`),
        h('span', { class: 'line' }, shown.text),
      );
      if (isCurrent) current = row;
      rows.push(row);
    }
    list.replaceChildren(...rows);
    if (current) list.scrollTop = Math.max(0, current.offsetTop - list.clientHeight / 2);
  }

  function toggle(): void {
    if (playing) pause();
    else start();
  }

  function start(): void {
    if (!open || open.trace.samples.count < 2) return;
    const samples = open.trace.samples;
    // From the start again when at the end.
    if (open.index >= samples.count - 1) show(0);
    playT = samples.tNs[open.index] ?? 0;
    playing = true;
    play.textContent = 'Pause';
    play.setAttribute('data-playing', '1');
    lastFrame = performance.now();
    raf = requestAnimationFrame(step);
  }

  function pause(): void {
    playing = false;
    cancelAnimationFrame(raf);
    play.textContent = 'Play';
    play.setAttribute('data-playing', '0');
  }

  /** Playback in the trace's own time: one second of trace per second. */
  function step(now: number): void {
    if (!playing || !open) return;
    const samples = open.trace.samples;
    playT += (now - lastFrame) * 1e6;
    lastFrame = now;
    const end = samples.tNs[samples.count - 1] ?? 0;
    const k = playT >= end ? samples.count - 1 : samples.indexAt(playT);
    if (k !== open.index) show(k);
    if (playT >= end) {
      pause();
      return;
    }
    raf = requestAnimationFrame(step);
  }

  function close(): void {
    pause();
    const wasOpen = open !== null;
    open = null;
    listKey = '';
    error.textContent = '';
    bar.removeAttribute('data-error');
    note.textContent = '';
    fileInfo.textContent = 'No trace open: the view shows the live robot.';
    fileInfo.title = '';
    closeBtn.hidden = true;
    player.hidden = true;
    bar.setAttribute('data-open', '0');
    list.replaceChildren();
    if (wasOpen) sim.showRecorded(null);
  }

  return { openBytes, close };
}
