import { describe, expect, it } from 'vitest';
import { EditorState } from '@codemirror/state';
import { toCmDiagnostics } from './editor';
import type { Diag } from '../protocol/protocol';

const doc = EditorState.create({ doc: 'HOME\nPRINT TOTAL\n\nMOVEP POSE(900, 0, 0, 0)' }).doc;
const d = (line: number, col: number, severity: Diag['severity'] = 'error'): Diag => ({
  file: 'p.wrl',
  line,
  col,
  severity,
  message: 'm',
});

describe('toCmDiagnostics', () => {
  it('spans the word at line:col', () => {
    const [x] = toCmDiagnostics(doc, [d(2, 7)]);
    expect(doc.sliceString(x.from, x.to)).toBe('TOTAL');
    expect(x.severity).toBe('error');
    expect(x.source).toBe('p.wrl:2:7');
  });

  it('marks a constructor or a single character', () => {
    const [a, b] = toCmDiagnostics(doc, [d(4, 7, 'warning'), d(4, 11)]);
    expect(doc.sliceString(a.from, a.to)).toBe('POSE');
    expect(a.severity).toBe('warning');
    expect(doc.sliceString(b.from, b.to)).toBe('(');
  });

  it('marks the last character for a column past the end, and clamps lines', () => {
    const [a, b, c] = toCmDiagnostics(doc, [d(1, 99), d(99, 1), d(3, 1)]);
    expect(doc.sliceString(a.from, a.to)).toBe('E');
    expect(b.from).toBe(doc.line(4).from);
    expect(c.from).toBe(c.to); // an empty line: a point
  });
});
