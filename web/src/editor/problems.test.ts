import { describe, expect, it } from 'vitest';
import { EditorState } from '@codemirror/state';
import { charOffset, problemCounts, problemPlace, toCmDiagnostics, type Problem } from './problems';

const doc = EditorState.create({ doc: 'HOME\nPRINT TOTAL\n\nMOVEP POSE(900, 0, 0, 0)\nPRINT "😀", WAFER$("LP1", 1)' }).doc;
const p = (line: number, col: number, more: Partial<Problem> = {}): Problem => ({
  file: null,
  line,
  col,
  severity: 'error',
  message: 'm',
  ...more,
});

describe('toCmDiagnostics', () => {
  it('spans the word at line:col when no length is given', () => {
    const [x] = toCmDiagnostics(doc, [p(2, 7, { source: 'p.wrl:2:7' })]);
    expect(doc.sliceString(x.from, x.to)).toBe('TOTAL');
    expect(x.severity).toBe('error');
    expect(x.source).toBe('p.wrl:2:7');
  });

  it('spans the length the compiler gives, in characters', () => {
    const [a] = toCmDiagnostics(doc, [p(4, 7, { len: 4, severity: 'warning' })]);
    expect(doc.sliceString(a.from, a.to)).toBe('POSE');
    expect(a.severity).toBe('warning');
    expect(a.source).toBe('4:7');
    // Column 12 counts the emoji as one character (two UTF-16 units in the editor).
    const [b] = toCmDiagnostics(doc, [p(5, 12, { len: 6 })]);
    expect(doc.sliceString(b.from, b.to)).toBe('WAFER$');
  });

  it('marks a constructor or a single character', () => {
    const [a, b] = toCmDiagnostics(doc, [p(4, 7), p(4, 11)]);
    expect(doc.sliceString(a.from, a.to)).toBe('POSE');
    expect(doc.sliceString(b.from, b.to)).toBe('(');
  });

  it('marks the last character for a column past the end, and clamps lines', () => {
    const [a, b, c] = toCmDiagnostics(doc, [p(1, 99), p(99, 1), p(3, 1)]);
    expect(doc.sliceString(a.from, a.to)).toBe('E');
    expect(b.from).toBe(doc.line(5).from);
    expect(c.from).toBe(c.to); // an empty line: a point
  });

  it('leaves the problems of other files to the list', () => {
    expect(toCmDiagnostics(doc, [p(1, 1, { file: 'cell_lib' })])).toEqual([]);
  });
});

describe('problem helpers', () => {
  it('counts UTF-16 units of character columns', () => {
    expect(charOffset('a😀b', 1)).toBe(0);
    expect(charOffset('a😀b', 3)).toBe(3);
    expect(charOffset('ab', 9)).toBe(2);
  });

  it('names places and counts', () => {
    expect(problemPlace(p(4, 20))).toBe('4:20');
    expect(problemPlace(p(2, 5, { file: 'cell_lib' }))).toBe('cell_lib 2:5');
    expect(problemCounts([p(1, 1), p(2, 1), p(3, 1, { severity: 'warning' })])).toBe('2 errors, 1 warning');
    expect(problemCounts([])).toBe('');
  });
});
