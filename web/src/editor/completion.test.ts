import { describe, expect, it } from 'vitest';
import { EditorState } from '@codemirror/state';
import { CompletionContext } from '@codemirror/autocomplete';
import {
  completionOptions,
  findDefinition,
  inStringOrComment,
  routineAt,
  wordAt,
  wrlCompletionSource,
  type LanguageInfo,
  type SymbolInfo,
} from './completion';

const PROGRAM = `COUNT = 0
CALL fill(3)
SUB fill(n)
  LOCAL k = n * 2
  COUNT = COUNT + k
ENDSUB
PRINT COUNT
FUNCTION twice(x)
  RETURN x * 2
ENDFUNCTION
`;
const lines = PROGRAM.split('\n');
const lineText = (n: number) => lines[n - 1] ?? '';

const sym = (name: string, kind: string, line: number, scope: string | null = null, file = 0): SymbolInfo => ({
  name,
  kind,
  type: kind === 'sub' ? '' : 'number',
  file,
  line,
  col: 1,
  scope,
  detail: '',
});
const SYMBOLS: SymbolInfo[] = [
  sym('COUNT', 'variable', 1),
  sym('fill', 'sub', 3),
  sym('n', 'parameter', 3, 'fill'),
  sym('k', 'local', 4, 'fill'),
  sym('twice', 'function', 8),
  sym('x', 'parameter', 8, 'twice'),
  sym('SAFE', 'point', 0),
  sym('greet', 'sub', 1, null, 1),
];
const LANGUAGE: LanguageInfo = {
  functions: [{ name: 'SLOT', syntax: 'SLOT(station, n)', summary: 'the map state of a slot' }],
  statements: [
    { keyword: 'WAIT', syntax: 'WAIT OPERATOR [text]', summary: 'wait for the operator' },
    { keyword: 'WAIT', syntax: 'WAIT IN(n) = 0|1 [TIMEOUT seconds]', summary: 'wait for an input' },
    { keyword: 'MOVEL', syntax: 'MOVEL pose [SPEED pct]', summary: 'straight line' },
  ],
  keywords: ['ENDTRY', 'TRY', 'WAIT'],
};

describe('scopes and words', () => {
  it('finds the SUB or FUNCTION around a line', () => {
    expect(routineAt(lineText, 1)).toBeNull();
    expect(routineAt(lineText, 3)).toBe('fill');
    expect(routineAt(lineText, 5)).toBe('fill');
    expect(routineAt(lineText, 6)).toBe('fill');
    expect(routineAt(lineText, 7)).toBeNull();
    expect(routineAt(lineText, 9)).toBe('twice');
  });

  it('tells strings and comments', () => {
    expect(inStringOrComment('PRINT "abc')).toBe(true);
    expect(inStringOrComment('PRINT "a" + b')).toBe(false);
    expect(inStringOrComment("X = 1 ' a comm")).toBe(true);
    expect(inStringOrComment('PRINT "it\'s" + x')).toBe(false);
  });

  it('reads the name at a place', () => {
    expect(wordAt('PRINT WAFER$("LP1", n)', 8)).toEqual({ from: 6, to: 12, word: 'WAFER$' });
    expect(wordAt('X = COUNT + 1', 9)).toEqual({ from: 4, to: 9, word: 'COUNT' });
    expect(wordAt('X = 12', 5)).toBeNull();
  });
});

describe('definitions', () => {
  it("prefers the routine's own names, then globals", () => {
    expect(findDefinition(SYMBOLS, 'n', 'fill')?.kind).toBe('parameter');
    expect(findDefinition(SYMBOLS, 'n', null)).toBeNull();
    expect(findDefinition(SYMBOLS, 'x', 'fill')).toBeNull();
    expect(findDefinition(SYMBOLS, 'count', 'fill')?.line).toBe(1);
    expect(findDefinition(SYMBOLS, 'GREET', null)?.file).toBe(1);
  });
});

describe('completion', () => {
  it('offers the names in scope first, then the language', () => {
    const top = completionOptions(LANGUAGE, SYMBOLS, null).map((c) => c.label);
    expect(top).toContain('COUNT');
    expect(top).toContain('SAFE');
    expect(top).not.toContain('k');
    expect(top).toContain('WAIT OPERATOR');
    expect(top).toContain('WAIT');
    expect(top).toContain('SLOT');
    expect(top.filter((l) => l === 'WAIT')).toHaveLength(1);
    const inFill = completionOptions(LANGUAGE, SYMBOLS, 'fill');
    expect(inFill.map((c) => c.label).slice(0, 2)).toEqual(['n', 'k']);
    expect(inFill.find((c) => c.label === 'k')?.detail).toContain('local of fill');
    expect(inFill.find((c) => c.label === 'SLOT')?.detail).toBe('SLOT(station, n)');
  });

  const complete = (doc: string, explicit = false) => {
    const state = EditorState.create({ doc });
    const source = wrlCompletionSource({ language: () => LANGUAGE, symbols: () => SYMBOLS });
    return source(new CompletionContext(state, doc.length, explicit));
  };

  it('completes the word being typed, in its routine', () => {
    const r = complete('SUB fill(n)\n  PRINT CO');
    expect(r?.from).toBe('SUB fill(n)\n  PRINT '.length);
    expect(r?.options.map((o) => o.label)).toContain('COUNT');
    expect(r?.options.map((o) => o.label)).toContain('n');
  });

  it('offers fields after a dot, and nothing in a string or comment', () => {
    expect(complete('PRINT P.Y')?.options.map((o) => o.label)).toContain('YAW');
    expect(complete('PRINT "CO')).toBeNull();
    expect(complete("' CO")).toBeNull();
    expect(complete('X = ')).toBeNull();
    expect(complete('X = ', true)?.options.length).toBeGreaterThan(0);
  });
});
