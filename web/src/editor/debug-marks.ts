// The debugger's marks in the CodeMirror editor: breakpoints (a gutter of red dots, toggled by a
// click there or on a line number; they move with the text as it is edited) and the line the
// running program stands at (highlighted). The editor sends the BREAK requests.

import { RangeSet, StateEffect, StateField, type EditorState, type Extension } from '@codemirror/state';
import { Decoration, EditorView, GutterMarker, gutter, type BlockInfo, type DecorationSet } from '@codemirror/view';

const setBreakpoint = StateEffect.define<{ pos: number; on: boolean }>({
  map: (v, mapping) => ({ pos: mapping.mapPos(v.pos), on: v.on }),
});
const clearBreakpoints = StateEffect.define<null>();

class BreakpointMarker extends GutterMarker {
  override eq(other: GutterMarker): boolean {
    return other instanceof BreakpointMarker;
  }
  override toDOM(): Node {
    const dot = document.createElement('span');
    dot.className = 'cm-breakpoint-dot';
    dot.textContent = '●';
    return dot;
  }
}
const breakpointMarker = new BreakpointMarker();

/** The gutter's width, without a dot that could be taken for a breakpoint. */
class SpacerMarker extends GutterMarker {
  override eq(other: GutterMarker): boolean {
    return other instanceof SpacerMarker;
  }
  override toDOM(): Node {
    const s = document.createElement('span');
    s.textContent = '●';
    return s;
  }
}

/** The breakpoints: a marker at the start of each line that has one. */
export const breakpointField = StateField.define<RangeSet<GutterMarker>>({
  create: () => RangeSet.empty,
  update(set, tr) {
    set = set.map(tr.changes);
    for (const e of tr.effects) {
      if (e.is(clearBreakpoints)) set = RangeSet.empty;
      else if (e.is(setBreakpoint)) {
        const at = tr.state.doc.lineAt(Math.min(e.value.pos, tr.state.doc.length)).from;
        set = set.update({ filter: (from) => tr.state.doc.lineAt(from).from !== at });
        if (e.value.on) set = set.update({ add: [breakpointMarker.range(at)] });
      }
    }
    return set;
  },
});

/** The lines [1-based] with a breakpoint, ascending, each once. */
export function breakpointLines(state: EditorState): number[] {
  const lines = new Set<number>();
  const set = state.field(breakpointField, false);
  if (!set) return [];
  for (let it = set.iter(); it.value !== null; it.next()) {
    lines.add(state.doc.lineAt(Math.min(it.from, state.doc.length)).number);
  }
  return [...lines].sort((a, b) => a - b);
}

/** The effect that sets (or clears) the breakpoint of line `line`. */
export function breakpointEffect(state: EditorState, line: number, on: boolean): StateEffect<unknown> {
  return setBreakpoint.of({ pos: state.doc.line(Math.min(Math.max(line, 1), state.doc.lines)).from, on });
}

/** The effects that make `lines` the breakpoints (lines past the end are dropped). */
export function breakpointsEffects(state: EditorState, lines: readonly number[]): StateEffect<unknown>[] {
  return [clearBreakpoints.of(null), ...lines.filter((l) => l >= 1 && l <= state.doc.lines).map((l) => breakpointEffect(state, l, true))];
}

/**
 * The breakpoint gutter. `toggled(line, on)` is told of every breakpoint a click set or
 * cleared; the same handler serves the line-number gutter (`lineNumberClick`).
 */
export function breakpointGutter(toggled: (line: number, on: boolean) => void): Extension {
  return [
    breakpointField,
    gutter({
      class: 'cm-breakpoint-gutter',
      markers: (v) => v.state.field(breakpointField),
      initialSpacer: () => new SpacerMarker(),
      domEventHandlers: { mousedown: (view, block) => toggleAt(view, block, toggled) },
    }),
    EditorView.baseTheme({
      '.cm-breakpoint-gutter .cm-gutterElement': { cursor: 'pointer', color: '#ff4d4f', paddingLeft: '3px', width: '14px' },
      '.cm-lineNumbers .cm-gutterElement': { cursor: 'pointer' },
    }),
  ];
}

/** Toggle the breakpoint of the line a gutter click was on. */
export function toggleAt(view: EditorView, block: BlockInfo, toggled: (line: number, on: boolean) => void): boolean {
  const line = view.state.doc.lineAt(block.from).number;
  const on = !breakpointLines(view.state).includes(line);
  view.dispatch({ effects: breakpointEffect(view.state, line, on) });
  toggled(line, on);
  return true;
}

// ---- the current line ----

const setDebugLine = StateEffect.define<number | null>();

/** The line the running program stands at (highlighted), until the next position or its end. */
export const debugLineField = StateField.define<DecorationSet>({
  create: () => Decoration.none,
  update(deco, tr) {
    deco = deco.map(tr.changes);
    for (const e of tr.effects) {
      if (!e.is(setDebugLine)) continue;
      if (e.value === null || e.value < 1 || e.value > tr.state.doc.lines) deco = Decoration.none;
      else deco = Decoration.set([Decoration.line({ class: 'cm-debug-line' }).range(tr.state.doc.line(e.value).from)]);
    }
    return deco;
  },
  provide: (f) => EditorView.decorations.from(f),
});

/** The line highlighted now (null: none). */
export function debugLine(state: EditorState): number | null {
  const deco = state.field(debugLineField, false);
  if (!deco) return null;
  const it = deco.iter();
  return it.value === null ? null : state.doc.lineAt(it.from).number;
}

/** Highlight line `line` (null: none) and bring it into view. */
export function showDebugLine(view: EditorView, line: number | null): void {
  if (debugLine(view.state) === line) return;
  const effects: StateEffect<unknown>[] = [setDebugLine.of(line)];
  if (line !== null && line >= 1 && line <= view.state.doc.lines) {
    effects.push(EditorView.scrollIntoView(view.state.doc.line(line).from, { y: 'nearest' }));
  }
  view.dispatch({ effects });
}

/** The effect alone, for tests and for a transaction of one's own. */
export function debugLineEffect(line: number | null): StateEffect<unknown> {
  return setDebugLine.of(line);
}
