import { describe, expect, it } from 'vitest';
import type { Bus, SimSample } from './bus';
import { ControllerModel, resumeRefusal } from './controller-model';
import { parseLine } from './protocol';
import { encodeSample, decodeSample } from './stream';

/** A bus whose events and samples the test sends; requests never answer. */
function fakeBus(connected = true) {
  const events = new Set<(name: string, body: string, line: string) => void>();
  const samples = new Set<(s: SimSample) => void>();
  const bus: Bus = {
    connected: () => connected,
    onConnection: () => () => undefined,
    robot: () => null,
    onRobot: () => () => undefined,
    onSample: (cb) => {
      samples.add(cb);
      return () => samples.delete(cb);
    },
    onEvent: (cb) => {
      events.add(cb);
      return () => events.delete(cb);
    },
    request: () => new Promise(() => undefined),
    upload: () => new Promise(() => undefined),
  };
  /** Deliver one controller line as the connection does (`EVT <name> <body>`). */
  const line = (raw: string): void => {
    const l = parseLine(raw);
    if (l.kind !== 'EVT') throw new Error(`not an event: ${raw}`);
    for (const cb of events) cb(l.name, l.body, l.line);
  };
  const sample = (s: SimSample): void => {
    for (const cb of samples) cb(s);
  };
  return { bus, line, sample };
}

function heldSample(): SimSample {
  return {
    seq: 1,
    timeNs: 10_000_000,
    state: 'HELD',
    homed: true,
    inputs: 0,
    outputs: 0,
    x: 250,
    y: 100,
    z: 20,
    yaw: 30,
    positions: [10, 20, 30, 20],
    pulses: [10000, 20000, 30000, 20000],
  };
}

describe('resumeRefusal (the RESUME button)', () => {
  const view = { connected: true, state: 'HELD' as const, owner: 'none' };

  it('is enabled only while a motion is held', () => {
    expect(resumeRefusal(view, true)).toBe('');
    for (const state of ['IDLE', 'MOVING', 'STOPPING', 'ERROR', 'ESTOP'] as const) {
      expect(resumeRefusal({ ...view, state }, true), state).toBe(`no motion is held (state ${state})`);
    }
    expect(resumeRefusal({ ...view, state: null }, true)).toBe('no motion is held (state unknown)');
  });

  it('needs a connection and control, like a motion', () => {
    expect(resumeRefusal({ ...view, connected: false }, false)).toBe('not connected');
    expect(resumeRefusal({ ...view, owner: 'tcp3' }, false)).toBe('control is held by tcp3');
  });
});

describe('ControllerModel and the HELD state', () => {
  it('follows EVT STATE through STOPPING, HELD and MOVING', () => {
    const { bus, line } = fakeBus();
    const model = new ControllerModel(bus);
    const seen: (string | null)[] = [];
    for (const s of ['MOVING', 'STOPPING', 'HELD']) {
      line(`EVT STATE ${s}`);
      seen.push(model.v.state);
    }
    expect(seen).toEqual(['MOVING', 'STOPPING', 'HELD']);
    expect(resumeRefusal(model.v, model.mayCommand())).toBe('');
    line('EVT STATE MOVING');
    expect(model.v.state).toBe('MOVING');
    expect(resumeRefusal(model.v, model.mayCommand())).toBe('no motion is held (state MOVING)');
  });

  it('learns HELD from a STATUS reply', () => {
    const { bus } = fakeBus();
    const model = new ControllerModel(bus);
    const ack = parseLine('ACK 3 state=HELD homed=1 speed=40 owner=gui0 err=0');
    if (ack.kind !== 'ACK') throw new Error('not an ACK');
    model.noteReply('STATUS', { ...ack, id: 3 });
    expect(model.v.state).toBe('HELD');
    expect(model.v.owner).toBe('gui0');
    // Another page holds control: the state is HELD but this page may not resume.
    expect(resumeRefusal(model.v, model.mayCommand())).toBe('control is held by gui0');
  });

  it('learns HELD from a simulator datagram (state byte 5)', () => {
    const { bus, sample } = fakeBus();
    const model = new ControllerModel(bus);
    const decoded = decodeSample(encodeSample(heldSample()));
    if (!decoded) throw new Error('the datagram did not decode');
    sample(decoded);
    expect(model.v.state).toBe('HELD');
  });

  it('leaves RESUME disabled while disconnected, even after EVT STATE HELD', () => {
    const { bus, line } = fakeBus(false);
    const model = new ControllerModel(bus);
    line('EVT STATE HELD');
    expect(resumeRefusal(model.v, model.mayCommand())).toBe('not connected');
  });
});
