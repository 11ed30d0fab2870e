// CodeMirror 6 language for the robot language `.wrl` (docs/language.md): a stream tokenizer
// (one statement per line, `'` comments, `"…"` strings with `""`, case-insensitive keywords,
// names that may end in `$`), and a dark highlight style. Completion is completion.ts's.

import {
  HighlightStyle,
  LanguageSupport,
  StreamLanguage,
  StringStream,
  syntaxHighlighting,
  type StreamParser,
} from '@codemirror/language';
import type { CompletionSource } from '@codemirror/autocomplete';
import { tags as t } from '@lezer/highlight';
import type { Extension } from '@codemirror/state';

/** Block, flow and declaration keywords. */
export const CONTROL_KEYWORDS = [
  'IF', 'THEN', 'ELSEIF', 'ELSE', 'ENDIF', 'WHILE', 'ENDWHILE', 'FOR', 'TO', 'STEP', 'NEXT',
  'DO', 'LOOP', 'UNTIL', 'EXIT', 'SELECT', 'CASE', 'IS', 'ENDSELECT',
  'SUB', 'ENDSUB', 'FUNCTION', 'ENDFUNCTION', 'RETURN', 'CALL', 'PROGRAM', 'END',
  'TRY', 'CATCH', 'ENDTRY', 'RETRY', 'INCLUDE', 'DIM', 'LOCAL', 'AS',
] as const;

/** Statement keywords (crates/wrc-lang/src/statements.rs) and their option words. */
export const STATEMENT_KEYWORDS = [
  'HOME', 'MOVEJ', 'MOVEP', 'MOVEL', 'ARC', 'APPRO', 'APPROS', 'DEPART', 'DEPARTS', 'JOG',
  'SPEED', 'ACCEL', 'BLEND', 'DELAY', 'OUT', 'WAIT', 'OPERATOR', 'TIMEOUT', 'PRINT',
  'GET', 'PUT', 'SWAP', 'MAP', 'RAISE', 'ALARM', 'RESET', 'TEACH',
] as const;

/** Constructors and built-in functions (crates/wrc-lang/src/builtins.rs). */
export const BUILTINS = [
  'POSE', 'JOINTS', 'SIN', 'COS', 'TAN', 'ASIN', 'ACOS', 'ATAN2', 'SQRT', 'ABS', 'MIN', 'MAX',
  'ROUND', 'INT', 'SGN', 'STR$', 'FORMAT$', 'LEN', 'LEFT$', 'RIGHT$', 'MID$', 'VAL', 'UCASE$',
  'LCASE$', 'INSTR', 'HERE', 'IN', 'TIMER', 'DIST', 'RELTOOL', 'INFRAME', 'TOFRAME', 'ERR',
  'ERRMSG$', 'ERRLINE', 'OPERATOR$', 'SLOT', 'WAFER$', 'HAND$', 'SLOTS', 'PITCH', 'STATION',
  'APPROACH',
] as const;

/** Type names after `AS`. */
export const TYPE_NAMES = ['NUMBER', 'BOOLEAN', 'STRING', 'POSE', 'JOINTS'] as const;

const LOGIC = new Set(['AND', 'OR', 'NOT', 'MOD']);
const BOOLS = new Set(['TRUE', 'FALSE']);
/** Elbow postures (`MOVEP p, L`) and blades (`GET "LP1", 3, B`). */
const ATOMS: Record<string, Set<string>> = {
  MOVEP: new Set(['L', 'R', 'LEFT', 'RIGHT']),
  APPRO: new Set(['L', 'R', 'LEFT', 'RIGHT']),
  GET: new Set(['A', 'B']),
  PUT: new Set(['A', 'B']),
};
const CONTROL = new Set<string>(CONTROL_KEYWORDS);
const STATEMENTS = new Set<string>(STATEMENT_KEYWORDS);
const BUILTIN_SET = new Set<string>(BUILTINS);
const TYPES = new Set<string>(TYPE_NAMES);
/** Words after which a name is defined (`SUB name`, `DIM name`) or called (`CALL name`). */
const DEFINES = new Set(['SUB', 'FUNCTION', 'DIM', 'LOCAL']);

/** Tokenizer state: the line's first word (its statement) and what came just before. */
export interface WrlState {
  /** Upper-case first word of the current line, or '' before it. */
  stmt: string;
  /** The previous token was a `.` (a field follows: `.X`, `.YAW`, `.J1`). */
  afterDot: boolean;
  /** The previous word (upper case), for `SUB name` / `CALL name` / `AS type`; '' after
   * anything but a word. */
  prevWord: string;
}

/** The style names the tokenizer returns (highlight tags, see @lezer/highlight). */
export type WrlToken =
  | 'lineComment'
  | 'string'
  | 'number'
  | 'controlKeyword'
  | 'keyword'
  | 'logicOperator'
  | 'bool'
  | 'variableName.standard'
  | 'atom'
  | 'variableName.definition'
  | 'variableName.function'
  | 'typeName'
  | 'squareBracket'
  | 'propertyName'
  | 'variableName'
  | 'compareOperator'
  | 'arithmeticOperator'
  | 'paren'
  | 'separator'
  | 'punctuation'
  | 'invalid';

export const wrlParser: StreamParser<WrlState> = {
  name: 'wrl',
  startState: () => ({ stmt: '', afterDot: false, prevWord: '' }),
  copyState: (s) => ({ ...s }),
  token(stream: StringStream, state: WrlState): WrlToken | null {
    if (stream.sol()) {
      state.stmt = '';
      state.afterDot = false;
      state.prevWord = '';
    }
    if (stream.eatSpace()) return null;
    const afterDot = state.afterDot;
    state.afterDot = false;

    const ch = stream.peek();
    if (ch === "'") {
      stream.skipToEnd();
      return 'lineComment';
    }
    if (ch === '"') {
      stream.next();
      for (;;) {
        const c = stream.next() as string | undefined;
        if (c === undefined) return 'string'; // unclosed: the compiler says so
        if (c === '"') {
          if (stream.peek() === '"') stream.next();
          else return 'string';
        }
      }
    }
    if (stream.match(/^(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?/)) {
      return 'number';
    }
    const w = stream.match(/^[A-Za-z_][A-Za-z0-9_]*\$?/);
    if (w && typeof w !== 'boolean') {
      const word = w[0].toUpperCase();
      const prev = state.prevWord;
      const first = state.stmt === '';
      if (first) state.stmt = word;
      state.prevWord = word;
      if (afterDot) return 'propertyName';
      if (DEFINES.has(prev) && !CONTROL.has(word)) return 'variableName.definition';
      if (prev === 'CALL' && word !== 'PROGRAM') return 'variableName.function';
      if (prev === 'AS' && TYPES.has(word)) return 'typeName';
      if (CONTROL.has(word)) return 'controlKeyword';
      if (STATEMENTS.has(word)) return 'keyword';
      if (LOGIC.has(word)) return 'logicOperator';
      if (BOOLS.has(word)) return 'bool';
      if (BUILTIN_SET.has(word)) return 'variableName.standard';
      if (!first && ATOMS[state.stmt]?.has(word)) return 'atom';
      return 'variableName';
    }
    state.prevWord = '';
    if (stream.match(/^(?:<=|>=|<>|=|<|>)/)) {
      if (state.stmt === '') state.stmt = '=';
      return 'compareOperator';
    }
    const c = (stream.next() as string | undefined) ?? '';
    if (state.stmt === '') state.stmt = c;
    switch (c) {
      case '+':
      case '-':
      case '*':
      case '/':
        return 'arithmeticOperator';
      case '(':
      case ')':
        return 'paren';
      case '[':
      case ']':
        return 'squareBracket';
      case ',':
        return 'separator';
      case '.':
        state.afterDot = true;
        return 'punctuation';
      default:
        return 'invalid';
    }
  },
  languageData: {
    commentTokens: { line: "'" },
  },
};

export const wrlLanguage = StreamLanguage.define(wrlParser);

/** Tokens of one line, for tests: `[text, style]` pairs (blanks skipped). */
export function tokenizeLine(line: string, state: WrlState = wrlParser.startState!(2)): [string, string][] {
  const out: [string, string][] = [];
  const stream = new StringStream(line, 2, 2);
  while (!stream.eol()) {
    const style = wrlParser.token(stream, state);
    const text = line.slice(stream.start, stream.pos);
    if (stream.pos === stream.start) stream.next(); // never loop
    if (style) out.push([text, style]);
    stream.start = stream.pos;
  }
  return out;
}

/** Colours for the dark theme (keywords cyan, statements amber, strings green, …). */
export const wrlHighlightStyle = HighlightStyle.define([
  { tag: t.lineComment, color: '#6f7f8f', fontStyle: 'italic' },
  { tag: t.string, color: '#9ccc65' },
  { tag: t.number, color: '#f2a65a' },
  { tag: t.controlKeyword, color: '#c792ea', fontWeight: 'bold' },
  { tag: t.keyword, color: '#4fc3f7', fontWeight: 'bold' },
  { tag: t.logicOperator, color: '#c792ea' },
  { tag: t.bool, color: '#f78c6c' },
  { tag: t.standard(t.variableName), color: '#ffcb6b' },
  { tag: t.atom, color: '#f78c6c', fontWeight: 'bold' },
  { tag: t.definition(t.variableName), color: '#82aaff', fontWeight: 'bold' },
  { tag: t.function(t.variableName), color: '#82aaff' },
  { tag: t.propertyName, color: '#80cbc4' },
  { tag: t.variableName, color: '#e0e6ee' },
  { tag: [t.compareOperator, t.arithmeticOperator], color: '#89ddff' },
  { tag: t.typeName, color: '#80cbc4', fontStyle: 'italic' },
  { tag: [t.paren, t.squareBracket, t.separator, t.punctuation], color: '#a0aab4' },
  { tag: t.invalid, color: '#ff5370', textDecoration: 'underline wavy' },
]);

/**
 * The `.wrl` language with its highlighting; `autocomplete` (the editor's source, which knows
 * the program's names) is offered as the language's completion.
 */
export function wrl(autocomplete?: CompletionSource): Extension {
  return [
    new LanguageSupport(wrlLanguage, autocomplete ? [wrlLanguage.data.of({ autocomplete })] : []),
    syntaxHighlighting(wrlHighlightStyle),
  ];
}
