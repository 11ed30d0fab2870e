// The Editor panel: a CodeMirror 6 editor for `.wrl` programs, checked while typing by `wrc
// ui`'s compiler (no controller needed), with completion of the language and the program's own
// names and go-to-definition (F12, Ctrl/Cmd-click); Compile & Save (UPLOAD) with the
// controller's diagnostics; the debugger (debugger.ts: run, step, breakpoints, the current line,
// the operator's prompt), the Debug pane (watch, variables) and the Points panel beside it; a
// console with the program's PRINT output, its alarms and its end (INF or ABS, whose line is
// marked).
//
// Opening and naming are kept apart: **Open** shows a stored program or library (its text read
// by `wrc ui` from the program folder) or an example, **New…** starts a program under a new
// name, **Save as…** stores the text under another name; the program's name is never edited
// in place. While the program steps inside a library, the library's source is shown
// (read-only) with its current line. Questions (discard edits?) are dialogs that leave the
// E-STOP pressable, never the browser's blocking `confirm()`.

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
import { lintKeymap, setDiagnostics } from '@codemirror/lint';

import type { Bus } from '../protocol/bus';
import type { ControllerModel } from '../protocol/controller-model';
import type { ProgramTracker } from '../protocol/program-tracker';
import { h, setAttr } from '../dom';
import { askName, confirmAction } from '../panels/confirm-dialog';
import { fetchProgramNames, fetchProgramText, mergeNames } from './stored-programs';
import { LibraryPeek } from './library-peek';
import { diagsFromEvents, isProgramName, parsePrograms, type Diag } from '../protocol/protocol';
import { LiveCompiler, apiUrl, fetchLanguage, libraryFiles, type CompileRequest, type CompileResult } from './compile-client';
import { findDefinition, routineAt, wordAt, wrlCompletionSource, type LanguageInfo, type SymbolInfo } from './completion';
import { DebugPane } from './debug-pane';
import { breakpointGutter, breakpointLines, breakpointsEffects, debugLineField, toggleAt } from './debug-marks';
import { ProgramDebugger } from './debugger';
import type { ConsoleKind, EditorHost } from './host';
import { PointsPanel } from './points-panel';
import { charOffset, problemCounts, problemPlace, toCmDiagnostics, type Problem } from './problems';
import { wrl } from './wrl-language';
import fig7 from '../../../examples/fig7_ptp.wrl?raw';
import fig8 from '../../../examples/fig8_line.wrl?raw';
import pickPlace from '../../../examples/pick_place.wrl?raw';

export const DEFAULT_PROGRAM = `' demo.wrl — a short program: home, a PTP move, a straight line,
' at the bottom of the Z axis, where the arm passes under every station of the demo cell.
SPEED 50
HOME
MOVEP POSE(250, 100, 0, 30), L
MOVEL POSE(300, -50, 0, 0)
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

/** The controller's UPLOAD diagnostics (`EVT DIAG`) as problems of the editor's text. */
function uploadProblems(diags: readonly Diag[]): Problem[] {
  return diags.map((d) => ({ ...d, file: null, source: `${d.file}:${d.line}:${d.col}` }));
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
    '.cm-debug-line': { backgroundColor: 'rgba(255, 204, 0, 0.22)', boxShadow: 'inset 3px 0 0 #ffcc00' },
    '.cm-tooltip': { backgroundColor: '#1b232c', color: '#e0e6ee', border: '1px solid #34404d' },
    '.cm-tooltip-autocomplete > ul > li[aria-selected]': { backgroundColor: '#264f78' },
    '.cm-completionDetail': { color: '#8795a5', fontStyle: 'normal', marginLeft: '1em' },
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

/** What the editor follows. */
export interface EditorDeps {
  bus: Bus;
  /** Control (breakpoints wait for it). */
  model: ControllerModel;
  /** The running program (the debugger, the library's source while stepping in it). */
  program: ProgramTracker;
}

export function mountEditor(el: HTMLElement, deps: EditorDeps): EditorPanel {
  const { bus } = deps;
  el.classList.add('editor-panel');
  el.replaceChildren();

  const saved: Record<string, string> = load(STORE_SAVED, {});
  // The program in the editor, with its breakpoints, as the page left it.
  const current = load<{ name: string; text: string; breaks?: number[] }>(STORE_CURRENT, { name: 'demo', text: DEFAULT_PROGRAM });

  // ---- toolbar ----
  const nameEl = h('span', { class: 'program-name', 'data-testid': 'editor-name', title: 'The program in the editor' }, current.name);
  const newBtn = h('button', { class: 'btn small', 'data-testid': 'editor-new', title: 'Start a new program under a name', onclick: () => void newProgram() }, 'New…');
  const programs = h(
    'select',
    { 'data-testid': 'editor-open', 'aria-label': 'Open a stored program, library or example', title: 'Open a stored program or library (its text from the controller\u2019s program folder), or an example' },
    h('option', { value: '' }, 'Open…'),
  );
  const refreshBtn = h('button', { class: 'btn small', 'data-testid': 'editor-refresh', title: 'List the stored programs again (PROGRAMS)', onclick: () => void refreshPrograms() }, '⟳');
  const saveAsBtn = h('button', { class: 'btn small', 'data-testid': 'editor-save-as', title: 'Store this text under another name (UPLOAD)', onclick: () => void saveAs() }, 'Save as…');
  const compileBtn = h('button', { class: 'btn primary', 'data-testid': 'editor-compile', title: 'UPLOAD: compile and store on the controller (Ctrl+S)', onclick: () => void compile() }, 'Compile & Save');
  const status = h('div', { class: 'editor-status', 'data-testid': 'editor-status' });
  const statusAction = h('button', { class: 'btn small', 'data-testid': 'editor-status-action', hidden: true }, '');

  const toolbar = h(
    'div',
    { class: 'toolbar' },
    h('span', { class: 'field' }, h('span', { class: 'field-label' }, 'Program'), nameEl),
    newBtn,
    programs,
    refreshBtn,
    h('span', { class: 'spacer' }),
    saveAsBtn,
    compileBtn,
  );

  // ---- editor, side panes, problems and console ----
  const cmHost = h('div', { class: 'cm-host', 'data-testid': 'editor-cm' });
  const problems = h('div', { class: 'problems', 'data-testid': 'editor-problems' });
  const checkState = h('span', { class: 'check-state', 'data-testid': 'check-state', 'data-state': 'idle' }, '');
  const consoleEl = h('div', { class: 'console', 'data-testid': 'console' });
  const clearConsole = h('button', { class: 'btn small', onclick: () => consoleEl.replaceChildren() }, 'Clear');

  // ---- state ----
  let view!: EditorView;
  let saveTimer: ReturnType<typeof setTimeout> | null = null;
  let language: LanguageInfo | null = null;
  let symbols: SymbolInfo[] = [];
  let symbolFiles: string[] = [];

  function text(): string {
    return view.state.doc.toString();
  }
  let programName = current.name;
  /** The text as opened (a stored program, an example, a new one): unchanged, nothing is lost by replacing it. */
  let openedText: string | null = saved[current.name] ?? EXAMPLES.find((e) => e.name === current.name)?.text ?? null;
  function name(): string {
    return programName;
  }
  function setName(n: string): void {
    programName = n;
    nameEl.textContent = n;
  }
  function persist(): void {
    store(STORE_CURRENT, { name: name(), text: text(), breaks: breakpointLines(view.state) });
  }
  function edited(): boolean {
    return saved[name()] !== text();
  }
  function updateEdited(): void {
    el.setAttribute('data-edited', edited() ? '1' : '0');
  }
  function setStatus(msg: string, kind: 'ok' | 'err' | 'info' = 'info', action?: { label: string; run: () => void }): void {
    setAttr(status, 'data-kind', kind);
    status.textContent = msg;
    status.className = `editor-status ${kind}`;
    statusAction.hidden = !action;
    statusAction.textContent = action?.label ?? '';
    statusAction.onclick = action ? () => action.run() : null;
  }
  function say(textLine: string, kind: ConsoleKind = 'info'): void {
    consoleEl.append(h('div', { class: `con-${kind}` }, textLine));
    while (consoleEl.childElementCount > 1000) consoleEl.firstElementChild?.remove();
    consoleEl.scrollTop = consoleEl.scrollHeight;
  }
  function markAbsLine(line: number | null): void {
    if (line !== null && edited()) return; // the line would name another text
    view.dispatch({ effects: setAbsLine.of(line) });
    if (line !== null && line >= 1 && line <= view.state.doc.lines) {
      view.dispatch({ effects: EditorView.scrollIntoView(view.state.doc.line(line).from, { y: 'center' }) });
    }
  }
  function jumpTo(line: number, col: number): void {
    const ln = view.state.doc.line(Math.min(Math.max(line, 1), view.state.doc.lines));
    const pos = ln.from + charOffset(ln.text, Math.max(col, 1));
    view.dispatch({ selection: { anchor: pos }, scrollIntoView: true });
    view.focus();
  }

  function showProblems(list: readonly Problem[]): void {
    view.dispatch(setDiagnostics(view.state, toCmDiagnostics(view.state.doc, list)));
    problems.replaceChildren();
    if (list.length === 0) {
      problems.append(h('div', { class: 'problem none' }, 'No problems.'));
      return;
    }
    for (const d of list) {
      const row = h(
        'div',
        {
          class: `problem ${d.severity}`,
          'data-testid': 'problem',
          'data-line': String(d.line),
          'data-file': d.file ?? '',
          title: d.file === null ? 'Go to this place' : `In ${d.file}`,
          onclick: () => {
            if (d.file === null) jumpTo(d.line, d.col);
            else offerOpen(d.file, d.line, d.col, `The problem is in ${d.file}, line ${d.line}.`);
          },
        },
        h('span', { class: 'sev' }, d.severity),
        h('span', { class: 'loc' }, problemPlace(d)),
        h('span', { class: 'msg' }, d.message),
      );
      problems.append(row);
    }
  }

  /** Say where something in another program is, offering to open it when this browser has its text. */
  function offerOpen(file: string, line: number, col: number, message: string): void {
    const t = saved[file];
    setStatus(
      message,
      'info',
      t === undefined
        ? undefined
        : {
            label: `Open ${file}`,
            run: () => {
              void openProgram(file, t).then((ok) => ok && jumpTo(line, col));
            },
          },
    );
  }

  // ---- the compiler of wrc ui, while typing ----
  function compileRequest(): CompileRequest {
    const n = isProgramName(name()) ? name() : 'program';
    return {
      name: n,
      source: text(),
      files: libraryFiles(text(), saved, n),
      points: points?.store.program === n ? points.store.toToml() : '',
    };
  }
  function setCheck(state: 'checking' | 'ok' | 'errors' | 'offline', label: string, title = ''): void {
    checkState.setAttribute('data-state', state);
    checkState.textContent = label;
    checkState.title = title;
  }
  const live = new LiveCompiler({
    fetch: (url, init) => fetch(url, init),
    url: apiUrl('compile', window.location),
    onStart: () => setCheck('checking', 'checking…'),
    onResult: (r: CompileResult, req) => {
      if (req.source !== text()) return; // a newer compile follows
      if (r.ok || r.symbols.length > 0) {
        symbols = r.symbols;
        symbolFiles = r.files;
      }
      const list: Problem[] = r.diagnostics.map((d) => ({ ...d }));
      showProblems(list);
      const counts = problemCounts(list);
      if (r.ok) setCheck('ok', `compiles: ${r.instructions} instructions${counts ? `; ${counts}` : ''}`);
      else setCheck('errors', counts || 'does not compile');
      if (language === null) loadLanguage();
    },
    onError: (message) => setCheck('offline', 'cannot check', `wrc ui's compiler: ${message}`),
  });
  function recheck(): void {
    // Checking from now on: what the state says is for the text as it is.
    setCheck('checking', 'checking…');
    live.schedule(compileRequest);
  }
  function loadLanguage(): void {
    fetchLanguage((url, init) => fetch(url, init), apiUrl('language', window.location))
      .then((l) => {
        language = l;
      })
      .catch(() => undefined); // asked again after the next compile
  }

  // ---- go to definition ----
  function goToDefinition(pos: number): boolean {
    const line = view.state.doc.lineAt(pos);
    const w = wordAt(line.text, pos - line.from);
    if (!w) return false;
    const routine = routineAt((n) => view.state.doc.line(n).text, line.number);
    const s = findDefinition(symbols, w.word, routine);
    if (!s) {
      const upper = w.word.toUpperCase();
      const builtin = language?.functions.find((f) => f.name === upper);
      const statement = language?.statements.find((f) => f.keyword === upper);
      const what = builtin ?? statement;
      if (what) setStatus(`${upper} is part of the language: ${what.syntax} — ${what.summary}`, 'info');
      else setStatus(`${w.word}: no definition known (the last check did not define it)`, 'info');
      return true;
    }
    if (s.kind === 'point') {
      points?.highlight(s.name);
      setStatus(`${s.name} is a named point of ${name()}: see Points.`, 'info');
      return true;
    }
    if (s.file === 0) {
      jumpTo(s.line, s.col);
      setStatus(`${s.name}: ${s.kind}${s.detail ? ` ${s.detail}` : ''}, line ${s.line}`, 'info');
      return true;
    }
    const file = symbolFiles[s.file] ?? `file ${s.file}`;
    offerOpen(file, s.line, s.col, `${s.name} is defined in ${file}, line ${s.line}.`);
    return true;
  }

  // ---- CodeMirror ----
  let dbg: ProgramDebugger | null = null;
  let points: PointsPanel | null = null;
  const toggled = (line: number, on: boolean) => {
    persist();
    void dbg?.toggled(line, on);
  };
  const extensions: Extension[] = [
    breakpointGutter(toggled),
    lineNumbers({ domEventHandlers: { mousedown: (v, block) => toggleAt(v, block, toggled) } }),
    highlightActiveLineGutter(),
    highlightSpecialChars(),
    history(),
    drawSelection(),
    indentOnInput(),
    bracketMatching(),
    closeBrackets(),
    autocompletion({ activateOnTyping: true }),
    highlightActiveLine(),
    highlightSelectionMatches(),
    keymap.of([
      { key: 'Mod-s', run: () => (void compile(), true) },
      { key: 'F5', run: () => (void dbg?.act('run'), true) },
      { key: 'F10', run: () => (void dbg?.act('stepOver'), true) },
      { key: 'F11', run: () => (void dbg?.act('step'), true) },
      { key: 'Shift-F11', run: () => (void dbg?.act('stepOut'), true) },
      { key: 'F12', run: (v) => goToDefinition(v.state.selection.main.head) },
      ...defaultKeymap,
      ...historyKeymap,
      ...searchKeymap,
      ...completionKeymap,
      ...lintKeymap,
      indentWithTab,
    ]),
    wrl(wrlCompletionSource({ language: () => language, symbols: () => symbols })),
    absLineField,
    debugLineField,
    darkTheme,
    EditorView.domEventHandlers({
      mousedown: (event, v) => {
        if (event.button !== 0 || !(event.ctrlKey || event.metaKey)) return false;
        const pos = v.posAtCoords({ x: event.clientX, y: event.clientY });
        if (pos === null || !goToDefinition(pos)) return false;
        event.preventDefault();
        return true;
      },
    }),
    EditorView.updateListener.of((u) => {
      if (!u.docChanged) return;
      // A red status (a refused save, a failed run) was about the text before this edit.
      if (status.classList.contains('err')) setStatus('Edited since: Compile & Save stores it.', 'info');
      if (saveTimer) clearTimeout(saveTimer);
      saveTimer = setTimeout(persist, 300);
      updateEdited();
      recheck();
    }),
  ];
  view = new EditorView({
    parent: cmHost,
    state: EditorState.create({ doc: current.text, extensions }),
  });
  if (Array.isArray(current.breaks)) view.dispatch({ effects: breakpointsEffects(view.state, current.breaks.filter(Number.isInteger)) });

  const host: EditorHost = { bus, view: () => view, program: name, say, setStatus: (m, k) => setStatus(m, k) };
  const debugPane = new DebugPane(host);
  dbg = new ProgramDebugger(
    host,
    {
      ensureStored: async () => !(edited() || !(name() in saved)) || compile(),
      markAbsLine,
      showDiagnostics: (diags) => showProblems(uploadProblems(diags)),
      stateChanged: (v) => debugPane.update(v),
    },
    deps.program,
    deps.model,
  );
  const peek = new LibraryPeek(cmHost, deps.program, name, (lib) => readStored(lib));
  points = new PointsPanel(host, recheck);

  const side = h('aside', { class: 'editor-side' }, debugPane.el, points.el);
  const bottom = h(
    'div',
    { class: 'editor-bottom' },
    h('div', { class: 'pane' }, h('div', { class: 'pane-title' }, h('span', {}, 'Problems'), checkState), problems),
    h('div', { class: 'pane' }, h('div', { class: 'pane-title' }, 'Console ', clearConsole), consoleEl),
  );
  el.append(
    toolbar,
    dbg.toolbar,
    h('div', { class: 'status-line' }, status, statusAction, dbg.position, dbg.programState),
    dbg.prompt,
    h('div', { class: 'editor-main' }, h('div', { class: 'cm-stack' }, cmHost, peek.el), side),
    bottom,
  );

  /** Upload the buffer (under `as`, default its own name); true when the controller stored it. */
  async function compile(as?: string): Promise<boolean> {
    const n = as ?? name();
    if (!isProgramName(n)) {
      setStatus('The program name must be 1-32 letters, digits, _ or -: store it with Save as….', 'err');
      return false;
    }
    if (!bus.connected()) {
      setStatus('Not connected to the controller: the program is checked here, but Compile & Save stores it there.', 'err');
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
    if (text() === body) showProblems(uploadProblems(diags));
    if (r.first.kind === 'ACK') {
      const lines = r.first.fields.lines ?? '?';
      const warnings = Number(r.first.fields.warnings ?? '0');
      saved[n] = body;
      store(STORE_SAVED, saved);
      if (n !== name()) {
        setName(n);
        persist();
        nameChanged();
      }
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

  /** The stored programs and libraries (the controller's list and wrc ui's folder), then the examples. */
  async function refreshPrograms(): Promise<void> {
    let fromController: string[] = [];
    if (bus.connected()) {
      try {
        const { first } = await bus.request('PROGRAMS');
        if (first.kind === 'ACK') fromController = parsePrograms(first.fields);
      } catch {
        /* shown by the connection state */
      }
    }
    const names = mergeNames(fromController, await fetchProgramNames((u) => fetch(u), window.location));
    programs.replaceChildren(
      h('option', { value: '' }, 'Open…'),
      h(
        'optgroup',
        { label: names.length ? `Stored on the controller (${names.length})` : 'Stored on the controller: none' },
        ...names.map((p) => h('option', { value: `stored:${p}` }, p)),
      ),
      h('optgroup', { label: 'Examples' }, ...EXAMPLES.map((e) => h('option', { value: `example:${e.name}` }, e.name))),
    );
    programs.value = '';
  }

  /** A stored program's text: wrc ui reads it from the program folder; else this browser's copy. */
  async function readStored(n: string): Promise<{ text: string; from: 'controller' | 'browser' } | { text: null; why: string }> {
    const r = await fetchProgramText((u) => fetch(u), window.location, n);
    if (r.ok) return { text: r.source, from: 'controller' };
    if (saved[n] !== undefined) return { text: saved[n], from: 'browser' };
    return { text: null, why: r.why };
  }

  function replaceText(t: string): void {
    openedText = t;
    view.dispatch({ changes: { from: 0, to: view.state.doc.length, insert: t } });
    // Another program: its breakpoints are its own (none yet).
    view.dispatch({ effects: breakpointsEffects(view.state, []) });
    view.dispatch(setDiagnostics(view.state, []));
    problems.replaceChildren();
    markAbsLine(null);
  }

  /** May the editor's text be replaced? Asks when it holds edits the operator made and did not store. */
  async function mayReplace(): Promise<boolean> {
    if (text().trim() === '' || text() === openedText || !edited()) return true;
    return confirmAction({
      title: `Discard the edits of ${name()}?`,
      text: `The text in the editor differs from what is stored as ${name()}. Opening another program drops these edits (Save as… keeps them under another name).`,
      ok: 'Discard edits',
      danger: true,
    });
  }

  /** Show program `n` with text `t` (stored as that text: it is what the controller has). */
  async function openProgram(n: string, t: string, storedText = true): Promise<boolean> {
    if (!(await mayReplace())) return false;
    setName(n);
    replaceText(t);
    if (storedText) {
      saved[n] = t;
      store(STORE_SAVED, saved);
    }
    persist();
    updateEdited();
    nameChanged();
    void dbg?.syncBreakpoints(true);
    return true;
  }

  /** Open a stored program or library by name. */
  async function openStored(n: string): Promise<void> {
    setStatus(`opening ${n}…`);
    const r = await readStored(n);
    if (r.text === null) {
      setStatus(`${n}: its text cannot be read (${r.why}). Run runs the stored program.`, 'err');
      return;
    }
    if (await openProgram(n, r.text, r.from === 'controller')) {
      setStatus(r.from === 'controller' ? `${n}: opened as stored on the controller.` : `${n}: opened from this browser's copy (wrc ui cannot read the program folder).`, 'ok');
    }
  }

  async function newProgram(): Promise<void> {
    const n = await askName({
      title: 'New program',
      text: 'Its name (1-32 letters, digits, _ or -). Compile & Save stores it on the controller.',
      ok: 'Create',
      check: (x) => (isProgramName(x) ? '' : 'A name is 1-32 letters, digits, _ or -.'),
    });
    if (n === null) return;
    if (await openProgram(n, saved[n] ?? `' ${n}.wrl\n`, false)) setStatus(`${n}: new program (not stored yet).`, 'info');
  }

  async function saveAs(): Promise<void> {
    const n = await askName({
      title: `Save ${name()} as…`,
      text: 'Store the text in the editor under this name (UPLOAD); the editor then edits that program.',
      ok: 'Save',
      initial: name(),
      check: (x) => (isProgramName(x) ? '' : 'A name is 1-32 letters, digits, _ or -.'),
    });
    if (n !== null) await compile(n);
  }

  function nameChanged(): void {
    points?.programChanged();
    dbg?.refresh();
    recheck();
  }

  programs.addEventListener('change', () => {
    const v = programs.value;
    programs.value = '';
    if (v.startsWith('stored:')) void openStored(v.slice('stored:'.length));
    else if (v.startsWith('example:')) {
      const ex = EXAMPLES.find((e) => e.name === v.slice('example:'.length));
      if (ex) void openProgram(ex.name, ex.text, false);
    }
  });

  // ---- events ----
  bus.onEvent((evName, body) => {
    if (evName === 'PRINT') say(body, 'print');
  });
  bus.onConnection((up) => {
    compileBtn.disabled = !up;
    saveAsBtn.disabled = !up;
    if (up) void refreshPrograms();
  });
  compileBtn.disabled = !bus.connected();
  saveAsBtn.disabled = !bus.connected();
  void refreshPrograms();
  updateEdited();
  loadLanguage();
  void live.now(compileRequest());

  return {
    view,
    resize: () => view.requestMeasure(),
  };
}
