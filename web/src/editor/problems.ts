// The editor's problems: the compiler's errors and warnings (from `wrc ui`'s compiler while
// typing, or from the controller's UPLOAD) as one list, and as CodeMirror diagnostics at their
// place in the text. Pure; unit-tested.

import type { EditorState } from '@codemirror/state';
import type { Diagnostic } from '@codemirror/lint';

/** One error or warning. */
export interface Problem {
  /** null: the program in the editor; else the library or called program it is in. */
  file: string | null;
  /** Line and column [1-based; the column in characters]. */
  line: number;
  col: number;
  /** Length of the marked span [characters]; absent: the word at the column. */
  len?: number;
  severity: 'error' | 'warning' | 'info';
  message: string;
  /** Where it is, as the problems list shows it (`4:20`, `cell_lib 2:5`). */
  source?: string;
}

/** The offset [UTF-16 code units, as CodeMirror counts] of character column `col` [1-based]
 * in `text` (past the end: the end). */
export function charOffset(text: string, col: number): number {
  let offset = 0;
  let chars = 1;
  for (const c of text) {
    if (chars >= col) return offset;
    offset += c.length;
    chars++;
  }
  return offset;
}

/**
 * CodeMirror diagnostics of the problems in the editor's own text: from `line:col` over `len`
 * characters, or to the end of the word there (at least one character, so it is visible).
 */
export function toCmDiagnostics(doc: EditorState['doc'], problems: readonly Problem[]): Diagnostic[] {
  const out: Diagnostic[] = [];
  for (const d of problems) {
    if (d.file !== null) continue;
    const lineNo = Math.min(Math.max(d.line, 1), doc.lines);
    const line = doc.line(lineNo);
    let from = line.from + charOffset(line.text, Math.max(d.col, 1));
    let to: number;
    const rest = line.text.slice(from - line.from);
    if (d.len !== undefined && d.len > 1) {
      to = from + charOffset(rest, d.len + 1);
    } else {
      const word = /^([A-Za-z0-9_.$]+|"[^"]*"?|\S)/.exec(rest);
      to = from + (word ? word[0].length : 0);
    }
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
      source: d.source ?? `${d.line}:${d.col}`,
    });
  }
  return out;
}

/** `4:20`, or `cell_lib 2:5` for a problem in another file. */
export function problemPlace(p: Problem): string {
  return `${p.file !== null ? `${p.file} ` : ''}${p.line}:${p.col}`;
}

/** Counts for the status: `2 errors, 1 warning`, or '' when there are none. */
export function problemCounts(problems: readonly Problem[]): string {
  const errors = problems.filter((p) => p.severity === 'error').length;
  const warnings = problems.filter((p) => p.severity === 'warning').length;
  const part = (n: number, what: string) => `${n} ${what}${n === 1 ? '' : 's'}`;
  return [errors ? part(errors, 'error') : '', warnings ? part(warnings, 'warning') : ''].filter((s) => s).join(', ');
}
