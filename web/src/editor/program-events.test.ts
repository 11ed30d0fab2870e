import { describe, expect, it } from 'vitest';
import { parseAlarm, parseBreaks, parsePoint, parseProgramDetail, parseVar, statusLine } from './program-events';

describe('EVT PROGRAM with its detail', () => {
  it('reads a run that starts, goes on and steps', () => {
    expect(parseProgramDetail('demo RUNNING files=demo,cell_lib')).toEqual({
      name: 'demo',
      state: 'RUNNING',
      files: ['demo', 'cell_lib'],
      step: false,
    });
    expect(parseProgramDetail('demo RUNNING')).toEqual({ name: 'demo', state: 'RUNNING', files: null, step: false });
    expect(parseProgramDetail('demo RUNNING step')).toEqual({ name: 'demo', state: 'RUNNING', files: null, step: true });
  });

  it('reads pauses with and without a position', () => {
    expect(parseProgramDetail('demo PAUSED cell_lib:30')).toEqual({ name: 'demo', state: 'PAUSED', at: { file: 'cell_lib', line: 30 } });
    expect(parseProgramDetail('demo PAUSED')).toEqual({ name: 'demo', state: 'PAUSED', at: null });
  });

  it('reads the operator prompt and the end', () => {
    expect(parseProgramDetail('demo WAITING demo:7 Load the cassette: answer ok')).toEqual({
      name: 'demo',
      state: 'WAITING',
      at: { file: 'demo', line: 7 },
      text: 'Load the cassette: answer ok',
    });
    expect(parseProgramDetail('demo WAITING demo:7')).toMatchObject({ text: '' });
    expect(parseProgramDetail('demo ENDED')).toEqual({ name: 'demo', state: 'ENDED' });
    expect(parseProgramDetail('demo')).toBeNull();
    expect(parseProgramDetail('demo EXPLODED')).toBeNull();
  });
});

describe('EVT VAR', () => {
  it('reads values of every type, strings with blanks included', () => {
    expect(parseVar('COUNT number 3')).toEqual({ name: 'COUNT', known: true, type: 'number', value: '3' });
    expect(parseVar('P pose POSE(250, 0, 10, 0)')).toEqual({ name: 'P', known: true, type: 'pose', value: 'POSE(250, 0, 10, 0)' });
    expect(parseVar('S string "say ""hi"" now"')).toMatchObject({ value: '"say ""hi"" now"' });
    expect(parseVar('A number[3] 1,2,3')).toMatchObject({ type: 'number[3]', value: '1,2,3' });
    expect(parseVar('E string ""')).toMatchObject({ value: '""' });
  });

  it('reads a name that is not in scope', () => {
    expect(parseVar('X unknown')).toEqual({ name: 'X', known: false, why: '' });
    expect(parseVar('M[1,2] unknown (VARS takes one index)')).toEqual({ name: 'M[1,2]', known: false, why: 'VARS takes one index' });
    expect(parseVar('')).toBeNull();
  });
});

describe('EVT POINT', () => {
  it('reads poses, joints and deletions', () => {
    expect(parsePoint('demo SAFE pose 250 0 10.5 -90')).toEqual({
      program: 'demo',
      name: 'SAFE',
      value: { kind: 'pose', x: 250, y: 0, z: 10.5, yaw: -90 },
    });
    expect(parsePoint('demo PARK joints -75 150 -75 0')).toEqual({
      program: 'demo',
      name: 'PARK',
      value: { kind: 'joints', joints: [-75, 150, -75, 0] },
    });
    expect(parsePoint('demo OLD deleted')).toEqual({ program: 'demo', name: 'OLD', value: null });
  });

  it('refuses what is not a point', () => {
    expect(parsePoint('demo SAFE pose 1 2 3')).toBeNull();
    expect(parsePoint('demo SAFE pose 1 2 x 4')).toBeNull();
    expect(parsePoint('demo SAFE')).toBeNull();
    expect(parsePoint('demo SAFE circle 1')).toBeNull();
  });
});

describe('status line, breaks and alarms', () => {
  it("reads the status stream's line=", () => {
    expect(statusLine('state=MOVING homed=1 speed=50 owner=gui0 err=0 j=1,2 x=0 y=0 z=0 yaw=0 line=1:12')).toEqual({ file: 1, line: 12 });
    expect(statusLine('state=IDLE homed=1 speed=50 owner=none err=0')).toBeNull();
  });

  it('reads the breakpoints a BREAK reply lists', () => {
    expect(parseBreaks('12,cell_lib:30,4')).toEqual({ lines: [12, 4], others: [{ file: 'cell_lib', line: 30 }] });
    expect(parseBreaks('none')).toEqual({ lines: [], others: [] });
    expect(parseBreaks(undefined)).toEqual({ lines: [], others: [] });
  });

  it("reads a program's alarm", () => {
    expect(parseAlarm('1001 demo cell_lib:12: vacuum low: check the pump')).toEqual({
      code: 1001,
      program: 'demo',
      at: { file: 'cell_lib', line: 12 },
      text: 'vacuum low: check the pump',
    });
    expect(parseAlarm('7 something else')).toEqual({ code: 7, program: '', at: null, text: 'something else' });
    expect(parseAlarm('no code')).toBeNull();
  });
});
