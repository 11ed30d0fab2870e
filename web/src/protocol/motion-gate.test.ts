import { describe, expect, it } from 'vitest';
import { motionRefusal, outputRefusal, type GateInput } from './motion-gate';

const ready: GateInput = { connected: true, state: 'IDLE', homed: true, owner: 'none', me: null, program: 'none' };

describe('motionRefusal (the controller admission rules, in their order)', () => {
  it('lets an idle, homed robot move while nobody or this page holds control', () => {
    expect(motionRefusal('move', ready)).toBe('');
    expect(motionRefusal('move', { ...ready, owner: 'gui0', me: 'gui0' })).toBe('');
    // A motion sent while another runs is queued.
    expect(motionRefusal('jog', { ...ready, state: 'MOVING' })).toBe('');
  });

  it('says who holds control, as the header names it', () => {
    expect(motionRefusal('move', { ...ready, owner: 'gui0', me: null, ownerText: 'another tab of this browser (gui0)' })).toBe(
      'control is held by another tab of this browser (gui0): take control once it is released',
    );
    expect(outputRefusal({ ...ready, owner: 'tcp3', me: 'gui1' })).toBe('control is held by tcp3: take control once it is released');
  });

  it('refuses in ESTOP and ERROR, while stopping or held, and says what comes first', () => {
    expect(motionRefusal('home', { ...ready, state: 'ESTOP' })).toBe('the robot is in ESTOP: release the E-stop and RESET first');
    expect(motionRefusal('jog', { ...ready, state: 'ERROR' })).toBe('the robot is in ERROR: RESET first');
    expect(motionRefusal('move', { ...ready, state: 'STOPPING' })).toBe('the robot is stopping: wait until it stands still');
    expect(motionRefusal('move', { ...ready, state: 'HELD' })).toBe('a motion is held: RESUME it, or STOP to abandon it');
  });

  it('refuses while a program runs, is paused or waits for the operator', () => {
    expect(motionRefusal('move', { ...ready, program: 'running', programName: 'wafer_cycle' })).toBe('wafer_cycle is running: ABORT it (Editor) first');
    expect(motionRefusal('home', { ...ready, program: 'paused', programName: 'wafer_cycle' })).toBe(
      'wafer_cycle is paused: CONTINUE or ABORT it (Editor) first',
    );
    expect(motionRefusal('jog', { ...ready, program: 'waiting' })).toContain('waits for the operator');
    // Outputs are not motions: a program does not lock them.
    expect(outputRefusal({ ...ready, program: 'running' })).toBe('');
  });

  it('refuses during a transfer, before anything about the state', () => {
    expect(motionRefusal('move', { ...ready, state: 'ESTOP', transfer: 'GET LP1.3 W3' })).toBe(
      'a transfer or mapping is in progress (GET LP1.3 W3): wait for its end or STOP',
    );
  });

  it('needs a homed robot for everything but HOME', () => {
    const unhomed = { ...ready, homed: false };
    expect(motionRefusal('home', unhomed)).toBe('');
    expect(motionRefusal('move', unhomed)).toBe('the robot is not homed: HOME first');
    expect(motionRefusal('jog', unhomed)).toBe('the robot is not homed: HOME first');
  });

  it('refuses everything offline', () => {
    expect(motionRefusal('home', { ...ready, connected: false })).toBe('not connected to the controller');
    expect(outputRefusal({ ...ready, connected: false })).toBe('not connected to the controller');
  });
});
