// The Editor panel: a CodeMirror 6 editor for `.wrl` programs, compile (UPLOAD) with the
// controller's diagnostics inline and in a problems list, run / pause / continue / abort, and a
// console with the program's PRINT output and its end (INF or ABS, whose line is marked).

import { EditorState, StateEffect, StateField, type Extension } from '@codemirror/state';
import {
  Decoration,
  EditorView,
  drawSelection,
  highlightActiveLine,
  highlightActiveLineGutter,
  highlightSpecialChars,
  keymap,
  lineNumbers,
  type DecorationSet,
} from '@codemirror/view';
import { defaultKeymap, history, historyKeymap, indentWithTab } from '@codemirror/commands';
import { bracketMatching, indentOnInput } from '@codemirror/language';
import { autocompletion, closeBrackets, completionKeymap } from '@codemirror/autocomplete';
import { highlightSelectionMatches, searchKeymap } from '@codemirror/search';
import { lintGutter, lintKeymap, setDiagnostics, type Diagnostic } from '@codemirror/lint';

import type { Bus } from '../protocol/bus';
import { h } from '../dom';
import {
  diagsFromEvents,
  isProgramName,
  parsePrograms,
  parseProgramEvent,
  programAbsLine,
  type Diag,
} from '../protocol/protocol';
import { wrl } from './wrl-language';
import fig7 from '../../../examples/fig7_ptp.wrl?raw';
import fig8 from '../../../examples/fig8_line.wrl?raw';
import pickPlace from '../../../examples/pick_place.wrl?raw';

export const DEFAULT_PROGRAM = `' demo.wrl — a short program: home, a PTP move, a straight line.
SPEED 50
HOME
MOVEP POSE(250, 100, 20, 30), L
MOVEL POSE(300, -50, 20, 0)
PRINT "demo done at", HERE()
END
`;

const EXAMPLES: { name: string; text: string }[] = [
  { name: 'demo', text: DEFAULT_PROGRAM },
  { name: 'fig7_ptp', text: fig7 },
  { name: 'fig8_line', text: fig8 },
  { name: 'pick_place', text: pickPlace },
];

const STORE_CURRENT = 'wrc.editor.current';
const STORE_SAVED = 'wrc.editor.saved';

function load<T>(key: string, fallback: T): T {
  try {
    const s = localStorage.getItem(key);
    return s ? (JSON.parse(s) as T) : fallback;
  } catch {
    return fallback;
  }
}

function store(key: string, value: unknown): void {
  try {
    localStorage.setItem(key, JSON.stringify(value));
  } catch {
    /* private mode or full: edits are only in memory */
  }
}

/**
 * CodeMirror diagnostics from the controller's: `line:col` (1-based, characters) to the end of
 * the word there (at least one character, so the range is visible).
 */
export function toCmDiagnostics(doc: EditorState['doc'], diags: Diag[]): Diagnostic[] {
  const out: Diagnostic[] = [];
  for (const d of diags) {
    const lineNo = Math.min(Math.max(d.line, 1), doc.lines);
    const line = doc.line(lineNo);
    let from = line.from + Math.max(d.col - 1, 0);
    if (from > line.to) from = line.to;
    const rest = line.text.slice(from - line.from);
    const word = /^([A-Za-z0-9_.]+|"[^"]*"?|\S)/.exec(rest);
    let to = from + (word ? word[0].length : 0);
    if (to === from) {
      // At the end of the line: mark the last character instead (or nothing on an empty line).
      if (from > line.from) from -= 1;
      to = Math.min(from + 1, line.to);
    }
    out.push({
      from,
      to,
      severity: d.severity,
      message: d.message,
      source: `${d.file}:${d.line}:${d.col}`,
    });
  }
  return out;
}

// The line an ABS named, marked until the next run or edit of the program.
const setAbsLine = StateEffect.define<number | null>();
const absLineField = StateField.define<DecorationSet>({
  create: () => Decoration.none,
  update(deco, tr) {
    deco = deco.map(tr.changes);
    for (const e of tr.effects) {
      if (e.is(setAbsLine)) {
        if (e.value === null || e.value < 1 || e.value > tr.state.doc.lines) deco = Decoration.none;
        else {
          const line = tr.state.doc.line(e.value);
          deco = Decoration.set([Decoration.line({ class: 'cm-abs-line' }).range(line.from)]);
        }
      }
    }
    return deco;
  },
  provide: (f) => EditorView.decorations.from(f),
});

const darkTheme = EditorView.theme(
  {
    '&': { color: '#e0e6ee', backgroundColor: '#10151b', height: '100%', fontSize: '13px' },
    '.cm-scroller': { fontFamily: 'ui-monospace, "DejaVu Sans Mono", Menlo, Consolas, monospace', lineHeight: '1.5' },
    '.cm-content': { caretColor: '#ffcc00' },
    '.cm-cursor, .cm-dropCursor': { borderLeftColor: '#ffcc00' },
    '&.cm-focused .cm-selectionBackground, .cm-selectionBackground, .cm-content ::selection': { backgroundColor: '#264f78' },
    '.cm-gutters': { backgroundColor: '#0c1116', color: '#5c6773', border: 'none', borderRight: '1px solid #222b35' },
    '.cm-activeLine': { backgroundColor: '#17202a' },
    '.cm-activeLineGutter': { backgroundColor: '#17202a', color: '#c0c8d0' },
    '.cm-abs-line': { backgroundColor: 'rgba(255, 60, 60, 0.22)', outline: '1px solid rgba(255,80,80,0.6)' },
    '.cm-tooltip': { backgroundColor: '#1b232c', color: '#e0e6ee', border: '1px solid #34404d' },
    '.cm-tooltip-autocomplete > ul > li[aria-selected]': { backgroundColor: '#264f78' },
    '.cm-diagnostic-error': { borderLeftColor: '#ff5370' },
    '.cm-diagnostic-warning': { borderLeftColor: '#ffb74d' },
  },
  { dark: true },
);

export interface EditorPanel {
  resize(): void;
  /** The CodeMirror view (tests, the shell). */
  view: EditorView;
}

export function mountEditor(el: HTMLElement, bus: Bus): EditorPanel {
  el.classList.add('editor-panel');
  el.replaceChildren();

  const saved: Record<string, string> = load(STORE_SAVED, {});
  const current = load<{ name: string; text: string }>(STORE_CURRENT, { name: 'demo', text: DEFAULT_PROGRAM });

  // ---- toolbar ----
  const nameInput = h('input', {
    type: 'text',
    class: 'name',
    'data-testid': 'editor-name',
    'aria-label': 'Program name',
    maxlength: '32',
    spellcheck: 'false',
    value: current.name,
  });
  const programs = h('select', { 'data-testid': 'editor-programs', 'aria-label': 'Stored programs' }, h('option', { value: '' }, 'stored programs…'));
  const refreshBtn = h('button', { class: 'btn small', 'data-testid': 'editor-refresh', title: 'PROGRAMS', onclick: () => void refreshPrograms() }, '⟳');
  const examples = h(
    'select',
    { 'data-testid': 'editor-example', 'aria-label': 'Examples' },
    h('option', { value: '' }, 'load example…'),
    ...EXAMPLES.map((e) => h('option', { value: e.name }, e.name)),
  );
  const compileBtn = h('button', { class: 'btn primary', 'data-testid': 'editor-compile', title: 'UPLOAD: compile and store', onclick: () => void compile() }, 'Compile & Save');
  const runBtn = h('button', { class: 'btn go', 'data-testid': 'editor-run', onclick: () => void run() }, '▶ Run');
  const pauseBtn = h('button', { class: 'btn', 'data-testid': 'editor-pause', onclick: () => void simple('PAUSE') }, '❚❚ Pause');
  const contBtn = h('button', { class: 'btn', 'data-testid': 'editor-continue', onclick: () => void simple('CONTINUE') }, 'Continue');
  const abortBtn = h('button', { class: 'btn warn', 'data-testid': 'editor-abort', onclick: () => void simple('ABORT') }, '■ Abort');
  const status = h('div', { class: 'editor-status', 'data-testid': 'editor-status' });
  const programState = h('span', { class: 'program-state', 'data-testid': 'program-state' }, '');

  const toolbar = h(
    'div',
    { class: 'toolbar' },
    h('label', { class: 'field' }, h('span', { class: 'field-label' }, 'Program'), nameInput),
    programs,
    refreshBtn,
    examples,
    h('span', { class: 'spacer' }),
    compileBtn,
    runBtn,
    pauseBtn,
    contBtn,
    abortBtn,
  );

  // ---- editor ----
  const cmHost = h('div', { class: 'cm-host', 'data-testid': 'editor-cm' });
  const problems = h('div', { class: 'problems', 'data-testid': 'editor-problems' });
  const consoleEl = h('div', { class: 'console', 'data-testid': 'console' });
  const clearConsole = h('button', { class: 'btn small', onclick: () => consoleEl.replaceChildren() }, 'Clear');
  const bottom = h(
    'div',
    { class: 'editor-bottom' },
    h('div', { class: 'pane' }, h('div', { class: 'pane-title' }, 'Problems'), problems),
    h('div', { class: 'pane' }, h('div', { class: 'pane-title' }, 'Console ', clearConsole), consoleEl),
  );
  el.append(toolbar, h('div', { class: 'status-line' }, status, programState), cmHost, bottom);

  let saveTimer: ReturnType<typeof setTimeout> | null = null;
  const extensions: Extension[] = [
    lineNumbers(),
    highlightActiveLineGutter(),
    highlightSpecialChars(),
    history(),
    drawSelection(),
    indentOnInput(),
    bracketMatching(),
    closeBrackets(),
    autocompletion({ activateOnTyping: false }),
    highlightActiveLine(),
    highlightSelectionMatches(),
    keymap.of([
      { key: 'Mod-s', run: () => (void compile(), true) },
      { key: 'F5', run: () => (void run(), true) },
      ...defaultKeymap,
      ...historyKeymap,
      ...searchKeymap,
      ...completionKeymap,
      ...lintKeymap,
      indentWithTab,
    ]),
    wrl(),
    lintGutter(),
    absLineField,
    darkTheme,
    EditorView.updateListener.of((u) => {
      if (!u.docChanged) return;
      if (saveTimer) clearTimeout(saveTimer);
      saveTimer = setTimeout(persist, 300);
      updateEdited();
    }),
  ];
  const view = new EditorView({
    parent: cmHost,
    state: EditorState.create({ doc: current.text, extensions }),
  });

  // ---- state ----
  function text(): string {
    return view.state.doc.toString();
  }
  function name(): string {
    return nameInput.value.trim();
  }
  function persist(): void {
    store(STORE_CURRENT, { name: name(), text: text() });
  }
  function edited(): boolean {
    return saved[name()] !== text();
  }
  function updateEdited(): void {
    el.setAttribute('data-edited', edited() ? '1' : '0');
  }
  function setStatus(msg: string, kind: 'ok' | 'err' | 'info' = 'info'): void {
    status.textContent = msg;
    status.className = `editor-status ${kind}`;
  }
  function say(textLine: string, kind: 'print' | 'info' | 'ok' | 'err' = 'info'): void {
    consoleEl.append(h('div', { class: `con-${kind}` }, textLine));
    while (consoleEl.childElementCount > 1000) consoleEl.firstElementChild?.remove();
    consoleEl.scrollTop = consoleEl.scrollHeight;
  }
  function markAbsLine(line: number | null): void {
    view.dispatch({ effects: setAbsLine.of(line) });
    if (line !== null && line >= 1 && line <= view.state.doc.lines) {
      view.dispatch({ effects: EditorView.scrollIntoView(view.state.doc.line(line).from, { y: 'center' }) });
    }
  }

  function showDiagnostics(diags: Diag[]): void {
    view.dispatch(setDiagnostics(view.state, toCmDiagnostics(view.state.doc, diags)));
    problems.replaceChildren();
    if (diags.length === 0) {
      problems.append(h('div', { class: 'problem none' }, 'No problems.'));
      return;
    }
    for (const d of diags) {
      const row = h(
        'div',
        {
          class: `problem ${d.severity}`,
          'data-testid': 'problem',
          'data-line': String(d.line),
          title: 'Go to this place',
          onclick: () => {
            const ln = view.state.doc.line(Math.min(Math.max(d.line, 1), view.state.doc.lines));
            const pos = Math.min(ln.from + Math.max(d.col - 1, 0), ln.to);
            view.dispatch({ selection: { anchor: pos }, scrollIntoView: true });
            view.focus();
          },
        },
        h('span', { class: 'sev' }, d.severity),
        h('span', { class: 'loc' }, `${d.line}:${d.col}`),
        h('span', { class: 'msg' }, d.message),
      );
      problems.append(row);
    }
  }

  /** Upload the buffer; true when the controller stored it. */
  async function compile(): Promise<boolean> {
    const n = name();
    if (!isProgramName(n)) {
      setStatus('The program name must be 1-32 letters, digits, _ or -.', 'err');
      nameInput.focus();
      return false;
    }
    if (!bus.connected()) {
      setStatus('Not connected to the controller.', 'err');
      return false;
    }
    const body = text();
    setStatus(`compiling ${n}…`);
    markAbsLine(null);
    let r: Awaited<ReturnType<Bus['upload']>>;
    try {
      r = await bus.upload(n, body);
    } catch (e) {
      setStatus(`Upload failed: ${e instanceof Error ? e.message : String(e)}`, 'err');
      return false;
    }
    const diags = diagsFromEvents(r.events);
    // The editor may have changed while compiling: diagnostics refer to the uploaded text.
    if (text() === body) showDiagnostics(diags);
    if (r.first.kind === 'ACK') {
      const lines = r.first.fields.lines ?? '?';
      const warnings = Number(r.first.fields.warnings ?? '0');
      saved[n] = body;
      store(STORE_SAVED, saved);
      updateEdited();
      setStatus(`${n}: compiled, ${lines} lines, stored${warnings ? `; ${warnings} warning${warnings === 1 ? '' : 's'}` : ''}.`, 'ok');
      void refreshPrograms();
      return true;
    }
    const errors = diags.filter((d) => d.severity === 'error').length;
    if (r.first.code === 126) {
      setStatus(`${n}: ${errors || 'some'} error${errors === 1 ? '' : 's'}, not stored (NAK 126 ${r.first.text})`, 'err');
    } else {
      setStatus(`NAK ${r.first.code} ${r.first.text}`, 'err');
    }
    return false;
  }

  async function run(): Promise<void> {
    const n = name();
    if (edited() || !(n in saved)) {
      if (!(await compile())) return;
    }
    markAbsLine(null);
    say(`> RUN ${n}`, 'info');
    let r: Awaited<ReturnType<Bus['request']>>;
    try {
      r = await bus.request(`RUN ${n}`);
    } catch (e) {
      say(`RUN ${n}: ${e instanceof Error ? e.message : String(e)}`, 'err');
      return;
    }
    const diags = diagsFromEvents(r.events);
    if (diags.length > 0) showDiagnostics(diags);
    if (r.first.kind === 'NAK') {
      say(`NAK ${r.first.code} ${r.first.text}`, 'err');
      setStatus(`RUN ${n} refused: ${r.first.code} ${r.first.text}`, 'err');
      return;
    }
    setStatus(`${n}: running`, 'ok');
    if (!r.final) return;
    try {
      const f = await r.final;
      if (f.kind === 'INF') {
        say(`INF program ${n} ended`, 'ok');
        setStatus(`${n}: program ended`, 'ok');
      } else {
        say(`ABS ${f.code} ${f.text}`, 'err');
        setStatus(`${n}: ended abnormally: ${f.code} ${f.text}`, 'err');
        const line = programAbsLine(f.text);
        if (line !== null && name() === n && !edited()) markAbsLine(line);
      }
    } catch (e) {
      say(`RUN ${n}: ${e instanceof Error ? e.message : String(e)}`, 'err');
    }
  }

  async function simple(verb: string): Promise<void> {
    say(`> ${verb}`, 'info');
    try {
      const { first } = await bus.request(verb);
      if (first.kind === 'ACK') say(`ACK ${verb}`, 'info');
      else say(`NAK ${first.code} ${first.text}`, 'err');
    } catch (e) {
      say(`${verb}: ${e instanceof Error ? e.message : String(e)}`, 'err');
    }
  }

  async function refreshPrograms(): Promise<void> {
    if (!bus.connected()) return;
    try {
      const { first } = await bus.request('PROGRAMS');
      if (first.kind !== 'ACK') return;
      const names = parsePrograms(first.fields);
      const keep = programs.value;
      programs.replaceChildren(
        h('option', { value: '' }, names.length ? `stored programs (${names.length})…` : 'no stored programs'),
        ...names.map((p) => h('option', { value: p }, p)),
      );
      programs.value = names.includes(keep) ? keep : '';
    } catch {
      /* shown by the connection state */
    }
  }

  function replaceText(t: string): void {
    view.dispatch({ changes: { from: 0, to: view.state.doc.length, insert: t } });
    view.dispatch(setDiagnostics(view.state, []));
    problems.replaceChildren();
    markAbsLine(null);
  }

  function openProgram(n: string, t: string | undefined): void {
    if (edited() && text().trim() !== '' && !confirm(`Discard the unsaved edits of ${name()}?`)) return;
    nameInput.value = n;
    if (t !== undefined) replaceText(t);
    else {
      // The controller keeps the program but does not give its text back: show a note and
      // treat it as unedited, so that Run runs what is stored.
      const note = `' ${n}: stored on the controller; its text was not saved in this browser.\n' Run runs the stored program; type a new text and Compile & Save to replace it.\n`;
      replaceText(note);
      saved[n] = note;
    }
    persist();
    updateEdited();
  }

  programs.addEventListener('change', () => {
    const n = programs.value;
    if (n) openProgram(n, saved[n]);
  });
  examples.addEventListener('change', () => {
    const ex = EXAMPLES.find((e) => e.name === examples.value);
    examples.value = '';
    if (ex) openProgram(ex.name, ex.text);
  });
  nameInput.addEventListener('input', () => {
    nameInput.classList.toggle('invalid', !isProgramName(name()));
    persist();
    updateEdited();
  });

  // ---- events ----
  bus.onEvent((evName, body) => {
    if (evName === 'PRINT') say(body, 'print');
    else if (evName === 'PROGRAM') {
      const p = parseProgramEvent(body);
      if (!p) return;
      say(`program ${p.name} ${p.state}`, 'info');
      programState.textContent = p.state === 'ENDED' ? '' : `${p.name}: ${p.state}`;
      programState.setAttribute('data-state', p.state);
    }
  });
  bus.onConnection((up) => {
    for (const b of [compileBtn, runBtn, pauseBtn, contBtn, abortBtn]) b.disabled = !up;
    if (up) void refreshPrograms();
  });
  for (const b of [compileBtn, runBtn, pauseBtn, contBtn, abortBtn]) b.disabled = !bus.connected();
  if (bus.connected()) void refreshPrograms();
  updateEdited();

  return {
    view,
    resize: () => view.requestMeasure(),
  };
}
