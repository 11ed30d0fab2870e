// What the editor knows of the language and of the program for completion and go-to-definition:
// the built-ins, statements and keywords (`GET /api/language`) and the names the last compile
// defined (`symbols` of `POST /api/compile`), with parameters and locals offered only inside
// their SUB or FUNCTION. Pure functions over text; the CodeMirror glue is `wrlCompletionSource`.

import type { Completion, CompletionContext, CompletionResult } from '@codemirror/autocomplete';

/** `GET /api/language`. */
export interface LanguageInfo {
  functions: { name: string; syntax: string; summary: string }[];
  statements: { keyword: string; syntax: string; summary: string }[];
  keywords: string[];
}

/** One name the compiler reported (wrc_lang::Symbol). */
export interface SymbolInfo {
  name: string;
  /** `variable`, `array`, `point`, `sub`, `function`, `parameter` or `local`. */
  kind: string;
  type: string;
  /** Index of its source file in the compile's `files` (0: the program). */
  file: number;
  /** Line and column [1-based]; a point's line is 0 (it is in the points file). */
  line: number;
  col: number;
  /** The SUB or FUNCTION a parameter or local belongs to. */
  scope: string | null;
  detail: string;
}

const ROUTINE_START = /^\s*(?:SUB|FUNCTION)[ \t]+([A-Za-z_][A-Za-z0-9_]*\$?)/i;
const ROUTINE_END = /^\s*(?:ENDSUB|ENDFUNCTION)\b/i;

/**
 * The SUB or FUNCTION whose body holds line `line` [1-based] of a text given line by line
 * (`lineText(n)`), or null at the top level.
 */
export function routineAt(lineText: (n: number) => string, line: number): string | null {
  for (let n = line; n >= 1; n--) {
    const t = lineText(n);
    if (n < line && ROUTINE_END.test(t)) return null;
    const m = ROUTINE_START.exec(t);
    if (m) return m[1];
  }
  return null;
}

/** Whether the end of `before` (a line's text up to the cursor) is in a string or a comment. */
export function inStringOrComment(before: string): boolean {
  let inString = false;
  for (const c of before) {
    if (c === '"') inString = !inString;
    else if (c === "'" && !inString) return true;
  }
  return inString;
}

/** A name of the language at offset `at` of `text` (`COUNT`, `WAFER$`): its span, or null. */
export function wordAt(text: string, at: number): { from: number; to: number; word: string } | null {
  const isWord = (c: string | undefined) => c !== undefined && /[A-Za-z0-9_$]/.test(c);
  let from = at;
  let to = at;
  while (from > 0 && isWord(text[from - 1])) from--;
  while (to < text.length && isWord(text[to])) to++;
  const word = text.slice(from, to);
  if (!/^[A-Za-z_][A-Za-z0-9_]*\$?$/.test(word)) return null;
  return { from, to, word };
}

/** The symbols visible in `routine` (null: the top level): its parameters and locals, then
 * the globals, SUBs, FUNCTIONs and points. */
export function visibleSymbols(symbols: readonly SymbolInfo[], routine: string | null): SymbolInfo[] {
  const r = routine?.toUpperCase() ?? null;
  const own = symbols.filter((s) => s.scope !== null && r !== null && s.scope.toUpperCase() === r);
  const globals = symbols.filter((s) => s.scope === null);
  return [...own, ...globals];
}

/** Where `word` is defined, seen from `routine`: a parameter or local of it first, then a
 * global name; null when the last compile did not define it. */
export function findDefinition(symbols: readonly SymbolInfo[], word: string, routine: string | null): SymbolInfo | null {
  const w = word.toUpperCase();
  return visibleSymbols(symbols, routine).find((s) => s.name.toUpperCase() === w) ?? null;
}

/** The label of a statement: its keyword, with a second keyword that makes it another
 * statement (`WAIT OPERATOR`). */
function statementLabel(syntax: string, keyword: string): string {
  const ws = syntax.split(' ');
  return ws.length > 1 && /^[A-Z]{2,}$/.test(ws[1]) && ws[0] === keyword ? `${ws[0]} ${ws[1]}` : keyword;
}

const KIND_TYPE: Record<string, string> = {
  variable: 'variable',
  array: 'variable',
  parameter: 'variable',
  local: 'variable',
  point: 'constant',
  sub: 'function',
  function: 'function',
};

/** Pose and joints fields, offered after a `.`. */
const FIELDS = ['X', 'Y', 'Z', 'YAW', 'J1', 'J2', 'J3', 'J4', 'J5', 'J6'];

/** Every completion at a place in `routine`: the program's names first (boosted), then the
 * statements, built-ins and keywords. */
export function completionOptions(lang: LanguageInfo | null, symbols: readonly SymbolInfo[], routine: string | null): Completion[] {
  const out: Completion[] = [];
  const seen = new Set<string>();
  const push = (c: Completion) => {
    const key = c.label.toUpperCase();
    if (seen.has(key)) return;
    seen.add(key);
    out.push(c);
  };
  for (const s of visibleSymbols(symbols, routine)) {
    const what = s.kind === 'parameter' || s.kind === 'local' ? `${s.kind} of ${s.scope}` : s.kind;
    const detail = [s.detail || s.type, what].filter((x) => x).join(' — ');
    push({ label: s.name, type: KIND_TYPE[s.kind] ?? 'variable', detail, boost: s.scope !== null ? 3 : 2 });
  }
  if (lang) {
    for (const st of lang.statements) {
      push({ label: statementLabel(st.syntax, st.keyword), type: 'keyword', detail: st.syntax, info: st.summary, boost: 1 });
    }
    for (const f of lang.functions) push({ label: f.name, type: 'function', detail: f.syntax, info: f.summary });
    for (const k of lang.keywords) push({ label: k, type: 'keyword' });
  }
  return out;
}

/** Where the completion model comes from (the editor keeps it up to date). */
export interface CompletionModel {
  language(): LanguageInfo | null;
  symbols(): readonly SymbolInfo[];
}

/** The CodeMirror completion source for `.wrl`. */
export function wrlCompletionSource(model: CompletionModel) {
  return (context: CompletionContext): CompletionResult | null => {
    const line = context.state.doc.lineAt(context.pos);
    const before = line.text.slice(0, context.pos - line.from);
    if (inStringOrComment(before)) return null;
    const word = context.matchBefore(/[A-Za-z_][A-Za-z0-9_]*\$?$/);
    // A field of a pose or joints value: `P.X`, `HERE().YAW`, `J[2].J1`.
    const field = /(?:[A-Za-z_][A-Za-z0-9_]*|\)|\])\.([A-Za-z0-9_]*)$/.exec(before);
    if (field) {
      return {
        from: context.pos - field[1].length,
        options: FIELDS.map((f) => ({ label: f, type: 'property' })),
        validFor: /^[A-Za-z0-9]*$/,
      };
    }
    if (!word && !context.explicit) return null;
    const routine = routineAt((n) => context.state.doc.line(n).text, line.number);
    return {
      from: word ? word.from : context.pos,
      options: completionOptions(model.language(), model.symbols(), routine),
      validFor: /^[A-Za-z_][A-Za-z0-9_]*\$?$/,
    };
  };
}
