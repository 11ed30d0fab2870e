import { describe, expect, it } from 'vitest';
import { DebugState, enabledActions, locate } from './debug-state';
import { actionRequest, answerOk } from './debugger';
import { parseProgramDetail } from './program-events';

function run(state: DebugState, ...bodies: string[]): void {
  for (const b of bodies) {
    const e = parseProgramDetail(b);
    if (!e) throw new Error(b);
    state.event(e);
  }
}

describe('DebugState', () => {
  it('follows a run: start, breakpoint, step, library, operator, end', () => {
    const s = new DebugState();
    run(s, 'demo RUNNING files=demo,cell_lib');
    expect(s.v).toMatchObject({ program: 'demo', state: 'running', files: ['demo', 'cell_lib'], position: null });
    s.statusLine({ file: 0, line: 3 });
    expect(s.v.position).toEqual({ fileIndex: 0, file: 'demo', line: 3 });
    run(s, 'demo PAUSED demo:5');
    expect(s.v).toMatchObject({ state: 'paused', position: { fileIndex: 0, line: 5 } });
    run(s, 'demo RUNNING step');
    expect(s.v.state).toBe('stepping');
    expect(s.v.files).toEqual(['demo', 'cell_lib']);
    run(s, 'demo PAUSED cell_lib:2');
    expect(s.v.position).toEqual({ fileIndex: 1, file: 'cell_lib', line: 2 });
    run(s, 'demo RUNNING', 'demo WAITING demo:9 Load the cassette');
    expect(s.v).toMatchObject({ state: 'waiting', prompt: 'Load the cassette', position: { line: 9 } });
    run(s, 'demo RUNNING');
    expect(s.v.prompt).toBeNull();
    run(s, 'demo ENDED');
    expect(s.v).toMatchObject({ program: null, state: 'none', position: null });
  });

  it('takes a line= of a program it did not see start as running, until it goes', () => {
    const s = new DebugState();
    expect(s.statusLine({ file: 0, line: 4 })).toBe(true);
    expect(s.v).toMatchObject({ program: null, state: 'running', position: { line: 4 } });
    expect(s.statusLine({ file: 0, line: 4 })).toBe(false);
    expect(s.statusLine(null)).toBe(true);
    expect(s.v.state).toBe('none');
  });

  it("ignores the ended program's last status lines", () => {
    const s = new DebugState();
    run(s, 'demo RUNNING files=demo', 'demo ENDED');
    expect(s.statusLine({ file: 0, line: 7 })).toBe(false);
    expect(s.v.state).toBe('none');
    s.statusLine(null);
    // Now a line= is a program's again.
    expect(s.statusLine({ file: 0, line: 1 })).toBe(true);
    expect(s.v.state).toBe('running');
  });

  it('learns a program from a pause it did not see start', () => {
    const s = new DebugState();
    run(s, 'other PAUSED other:3');
    expect(s.v).toMatchObject({ program: 'other', state: 'paused', files: ['other'], position: { fileIndex: 0, line: 3 } });
  });
});

describe('the buttons and the highlighted line', () => {
  it('enables what the controller would take', () => {
    const on = (state: Parameters<typeof enabledActions>[0]) =>
      Object.entries(enabledActions(state, true))
        .filter(([, v]) => v)
        .map(([k]) => k);
    expect(on('none')).toEqual(['run', 'runPaused']);
    expect(on('running')).toEqual(['pause', 'abort']);
    expect(on('stepping')).toEqual(['pause', 'abort']);
    expect(on('paused')).toEqual(['step', 'stepOver', 'stepOut', 'continue', 'abort']);
    expect(on('waiting')).toEqual(['continue', 'abort']);
    expect(Object.values(enabledActions('paused', false)).some((v) => v)).toBe(false);
  });

  it("highlights only the editor's own program's own file", () => {
    const s = new DebugState();
    run(s, 'demo RUNNING files=demo,cell_lib', 'demo PAUSED demo:5');
    expect(locate(s.v, 'demo')).toEqual({ line: 5, note: 'line 5' });
    expect(locate(s.v, 'other')).toEqual({ line: null, note: 'demo line 5' });
    run(s, 'demo RUNNING step', 'demo PAUSED cell_lib:2');
    expect(locate(s.v, 'demo')).toEqual({ line: null, note: 'in cell_lib line 2' });
    run(s, 'demo ENDED');
    expect(locate(s.v, 'demo')).toEqual({ line: null, note: '' });
  });

  it('makes the requests', () => {
    expect(actionRequest('run', 'demo')).toBe('RUN demo');
    expect(actionRequest('runPaused', 'demo')).toBe('RUN demo STEP');
    expect(actionRequest('stepOver', 'demo')).toBe('STEP OVER');
    expect(actionRequest('stepOut', 'demo')).toBe('STEP OUT');
    expect(actionRequest('continue', 'demo', 'ok_2')).toBe('CONTINUE ok_2');
    expect(actionRequest('continue', 'demo')).toBe('CONTINUE');
    expect(answerOk('ok_2-b')).toBe(true);
    expect(answerOk('two words')).toBe(false);
    expect(answerOk('x'.repeat(33))).toBe(false);
  });
});
