import { describe, expect, it } from 'vitest';
import { EditorState } from '@codemirror/state';
import { breakpointEffect, breakpointField, breakpointLines, breakpointsEffects, debugLine, debugLineEffect, debugLineField } from './debug-marks';

const make = (doc = 'A = 1\nB = 2\nC = 3\nD = 4\n') => EditorState.create({ doc, extensions: [breakpointField, debugLineField] });

describe('breakpoints in the editor', () => {
  it('toggle per line, each once', () => {
    let s = make();
    s = s.update({ effects: [breakpointEffect(s, 3, true)] }).state;
    s = s.update({ effects: [breakpointEffect(s, 1, true), breakpointEffect(s, 3, true)] }).state;
    expect(breakpointLines(s)).toEqual([1, 3]);
    s = s.update({ effects: [breakpointEffect(s, 3, false)] }).state;
    expect(breakpointLines(s)).toEqual([1]);
  });

  it('move with the text as it is edited', () => {
    let s = make();
    s = s.update({ effects: [breakpointEffect(s, 3, true)] }).state;
    s = s.update({ changes: { from: 0, insert: "' new first line\n" } }).state;
    expect(breakpointLines(s)).toEqual([4]);
    // Joining its line with the one above keeps one breakpoint on the joined line.
    s = s.update({ effects: [breakpointEffect(s, 3, true)] }).state;
    const l4 = s.doc.line(4);
    s = s.update({ changes: { from: l4.from - 1, to: l4.from } }).state;
    expect(breakpointLines(s)).toEqual([3]);
  });

  it('are replaced as a whole', () => {
    let s = make();
    s = s.update({ effects: breakpointsEffects(s, [2, 4, 99]) }).state;
    expect(breakpointLines(s)).toEqual([2, 4]);
    s = s.update({ effects: breakpointsEffects(s, []) }).state;
    expect(breakpointLines(s)).toEqual([]);
  });
});

describe('the current line', () => {
  it('is one line, or none', () => {
    let s = make();
    expect(debugLine(s)).toBeNull();
    s = s.update({ effects: [debugLineEffect(2)] }).state;
    expect(debugLine(s)).toBe(2);
    s = s.update({ effects: [debugLineEffect(99)] }).state;
    expect(debugLine(s)).toBeNull();
  });
});
