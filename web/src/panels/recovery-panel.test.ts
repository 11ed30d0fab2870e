import { describe, expect, it } from 'vitest';
import { recoveryFromReply, type RecoveryReport } from '../cell/recovery';
import { confirmChoices, finalReplyView, firstReplyView, recoveryPlan, type RecoveryInput } from './recovery-panel';

const NOTE = 'PUT LP2 1 (W1) was interrupted during step 2 (the approach and the straight line in); …';

/** A RECOVERY reply: the hand at (x, y), inside `inside` (or '-'), with these uncertain places. */
function report(inside: string, uncertain: string[]): RecoveryReport {
  return recoveryFromReply(`ACK 5 uncertain=${uncertain.length} inside=${inside}`, [
    `RECOVERY note ${NOTE}`,
    `RECOVERY hand x=183.27 y=105.81 z=31 yaw=30 inside=${inside}`,
    ...uncertain.map((u) => `RECOVERY uncertain ${u}`),
  ]).report;
}

const PUT_CUT = report('-', ['LP2.1 W1', 'hand W1']);
const STATIONS = [
  { name: 'LP2', speed: 60, slots: 25 },
  { name: 'PM1', speed: 15, slots: 1 },
];

/** After the restart: ERROR 216, not homed, nobody holds control. */
function input(over: Partial<RecoveryInput> = {}): RecoveryInput {
  return {
    report: PUT_CUT,
    connected: true,
    state: 'ERROR',
    homed: false,
    owner: 'none',
    holdsControl: false,
    err: 216,
    running: null,
    stations: STATIONS,
    ...over,
  };
}

/** In control, reset, homed: what the operator has after the first steps. */
const READY: Partial<RecoveryInput> = { owner: 'gui0', holdsControl: true, state: 'IDLE', homed: true, err: 0 };

const ids = (i: RecoveryInput) => recoveryPlan(i).steps.map((s) => s.id);
const step = (i: RecoveryInput, id: string) => recoveryPlan(i).steps.find((s) => s.id === id)!;

describe('recoveryPlan: the steps offered, in the operator’s order', () => {
  it('after a restart: take control, reset, home, sense the hand, map the station', () => {
    const p = recoveryPlan(input());
    expect(p.shown).toBe(true);
    expect(p.settled).toBe(false);
    expect(p.steps.map((s) => s.request)).toEqual(['CONTROL', 'RESET', 'HOME', 'SENSE', 'MAP LP2']);
    expect(p.next).toBe('control');
    expect(p.summary).toBe('Recovery needed: 2 uncertain places');
    // Only taking control may be pressed; the others say what comes first.
    expect(p.steps.map((s) => s.enabled)).toEqual([true, false, false, false, false]);
    expect(step(input(), 'reset').why).toBe('take control first');
    expect(step(input(), 'reset').label).toBe('Reset (clears alarm 216)');
  });

  it('shows RESET before a motion that ERROR would refuse (NAK 122), and HOME before SENSE and MAP (NAK 110)', () => {
    const held = input({ owner: 'gui0', holdsControl: true });
    expect(ids(held)).toEqual(['reset', 'home', 'sense-A', 'map-LP2']);
    expect(step(held, 'reset').enabled).toBe(true);
    expect(step(held, 'home').why).toBe('the robot is in ERROR: RESET first');
    expect(step(held, 'sense-A').why).toBe('the robot is in ERROR: RESET first');
    const reset = input({ owner: 'gui0', holdsControl: true, state: 'IDLE', err: 0 });
    expect(ids(reset)).toEqual(['home', 'sense-A', 'map-LP2']);
    expect(step(reset, 'home').enabled).toBe(true);
    expect(step(reset, 'sense-A').why).toBe('the robot is not homed: HOME first');
    expect(step(reset, 'map-LP2').why).toBe('the robot is not homed: HOME first');
    const homed = input(READY);
    expect(ids(homed)).toEqual(['sense-A', 'map-LP2']);
    expect(recoveryPlan(homed).steps.every((s) => s.enabled)).toBe(true);
    expect(recoveryPlan(homed).next).toBe('sense-A');
  });

  it('a hand inside a station: RETRACT or HOME first; SENSE and MAP wait (NAK 140)', () => {
    const r = report('LP2', ['LP2.1 W1', 'hand W1']);
    const i = input({ ...READY, report: r });
    expect(ids(i)).toEqual(['retract', 'home', 'sense-A', 'map-LP2']);
    expect(step(i, 'retract')).toMatchObject({ request: 'RETRACT', enabled: true, label: 'Retract out of LP2' });
    expect(step(i, 'home').label).toBe('Home (out of LP2 first)');
    expect(step(i, 'sense-A').why).toBe('the hand may be inside LP2: RETRACT (or HOME) first');
    expect(step(i, 'map-LP2').why).toBe('the hand may be inside LP2: RETRACT (or HOME) first');
    expect(recoveryPlan(i).summary).toBe('Recovery needed: 2 uncertain places · the hand may be inside LP2');
    // Retracting needs no homed robot: it is how an unhomed robot gets out.
    expect(step({ ...i, homed: false }, 'retract').enabled).toBe(true);
    // The hand inside with nothing uncertain still needs recovery.
    const only = input({ ...READY, report: report('PM1', []) });
    expect(ids(only)).toEqual(['retract', 'home']);
    expect(recoveryPlan(only).shown).toBe(true);
  });

  it('blade B and several stations: one SENSE per uncertain blade, one MAP per station with uncertain slots', () => {
    const r = report('-', ['LP2.1 W1', 'hand W1', 'PM1.1 W7', 'hand.B W7', 'LP2.3 W9']);
    const i = input({ ...READY, report: r });
    expect(recoveryPlan(i).steps.map((s) => s.request)).toEqual(['SENSE', 'SENSE B', 'MAP LP2', 'MAP PM1']);
    expect(step(i, 'sense-B').label).toBe('Sense blade B');
  });

  it('waits while a request runs, the robot moves or a motion is held', () => {
    expect(step(input({ ...READY, running: 'HOME' }), 'sense-A').why).toBe('HOME is running');
    expect(step(input({ ...READY, state: 'MOVING' }), 'map-LP2').why).toBe('the robot is moving: wait until it stands still');
    expect(step(input({ ...READY, state: 'HELD' }), 'map-LP2').why).toBe('a motion is held: RESUME or STOP it first');
    expect(step(input({ ...READY, state: 'ESTOP' }), 'map-LP2').why).toBe('the robot is in ESTOP: RESET first');
    expect(step(input({ ...READY, connected: false }), 'map-LP2').why).toBe('not connected to the controller');
  });

  it('another source holding control: say so rather than send what NAK 120 would refuse', () => {
    const i = input({ owner: 'tcp3' });
    const control = step(i, 'control');
    expect(control.enabled).toBe(false);
    expect(control.why).toBe('control is held by tcp3; it must release it first');
    expect(step(i, 'home').why).toBe('control is held by tcp3; it must release it first');
    expect(recoveryPlan(i).confirmEnabled).toBe(false);
  });

  it('settled but alarm 216 not reset: the panel stays with RESET only; then it goes', () => {
    const none = report('-', []);
    const p = recoveryPlan(input({ report: none, owner: 'gui0', holdsControl: true }));
    expect(p).toMatchObject({ shown: true, settled: true, next: 'reset', confirms: [] });
    expect(p.steps.map((s) => s.request)).toEqual(['RESET']);
    expect(p.summary).toBe('Alarm 216: nothing is uncertain any more; RESET clears it');
    const gone = recoveryPlan(input({ ...READY, report: none }));
    expect(gone.shown).toBe(false);
    expect(gone.steps).toEqual([]);
    // Another alarm is the header's business, not the recovery panel's.
    expect(recoveryPlan(input({ ...READY, report: none, state: 'ERROR', err: 203 })).shown).toBe(false);
  });
});

describe('recoveryPlan: what each dialog says will happen', () => {
  it('RETRACT: straight out at the station’s speed, at most 20 %', () => {
    const r = report('LP2', ['hand W1']);
    const text = step(input({ ...READY, report: r }), 'retract').confirm!;
    expect(text).toMatch(/^RETRACT: the hand moves straight out of LP2 along the station's line to its approach pose, at 20 %/);
    expect(text).toContain('W1 may lie unclamped on the blade');
    const slow = step(input({ ...READY, report: report('PM1', []) }), 'retract').confirm!;
    expect(slow).toContain('at 15 %'); // PM1's own speed is lower
  });

  it('HOME: the retract first when inside, slowly while a blade may hold an unclamped wafer', () => {
    const inside = step(input({ ...READY, homed: false, report: report('LP2', ['hand W1']) }), 'home').confirm!;
    expect(inside).toBe(
      'HOME: first the hand moves straight out of LP2 to its approach pose at 20 %, then every axis goes to its home position by a PTP move, slowly (at most 15 %: a blade may hold an unclamped wafer). Make sure the way is clear.',
    );
    const outside = step(input({ ...READY, homed: false, report: report('-', ['LP2.1 W1']) }), 'home').confirm!;
    expect(outside).toBe('HOME: every axis goes to its home position by a PTP move. Make sure the way is clear.');
  });

  it('SENSE: the vacuum on, nothing moves, and what either answer does to the map', () => {
    const text = step(input(READY), 'sense-A').confirm!;
    expect(text).toMatch(/^SENSE: the hand’s vacuum is switched on and its sensor read; the robot does not move\./);
    expect(text).toContain('If W1 is there, the vacuum clamps it and the wafer map keeps it on the blade, certain (LP2 slot 1 then becomes empty)');
    expect(text).toContain('W1 stays uncertain at LP2 slot 1 until a MAP');
    const alone = step(input({ ...READY, report: report('-', ['hand.B W7']) }), 'sense-B').confirm!;
    expect(alone).toMatch(/^SENSE B: blade B’s vacuum/);
    expect(alone).toContain('W7, nowhere else, leaves the map');
  });

  it('MAP: at the station’s speed once no blade is uncertain', () => {
    const text = step(input({ ...READY, report: report('-', ['LP2.1 W1']) }), 'map-LP2').confirm!;
    expect(text).toContain('straight up past slot 25 at 60 %. The wafer map takes');
  });

  it('never promises more than the operator’s speed override', () => {
    const slow = { ...READY, override: 10 };
    expect(step(input({ ...slow, report: report('LP2', ['hand W1']) }), 'retract').confirm).toMatch(/to its approach pose, at 10 %/);
    expect(step(input({ ...slow, report: report('-', ['LP2.1 W1']) }), 'map-LP2').confirm).toContain('past slot 25 at 10 %.');
    expect(step(input(slow), 'map-LP2').confirm).toContain('past slot 25 at 10 % (slowly');
    expect(step(input({ ...READY, override: 50, report: report('-', ['LP2.1 W1']) }), 'map-LP2').confirm).toContain('at 50 %.');
  });

  it('MAP: outside the station, a sweep up, and what the map takes', () => {
    const text = step(input(READY), 'map-LP2').confirm!;
    expect(text).toBe(
      "MAP LP2: the hand moves by PTP to LP2's approach pose below slot 1 (outside the station) and sweeps the mapping sensor straight up past slot 25 at 15 % (slowly: a blade may hold an unclamped wafer). The wafer map takes what the sensor finds in every slot of LP2: slot 1 (W1?) becomes that wafer if one is there, empty if not.",
    );
  });
});

describe('confirmChoices', () => {
  it('offers, per uncertain place, its wafer there or the place empty, and each wafer gone', () => {
    const c = confirmChoices(PUT_CUT);
    expect(c.map((x) => [x.label, x.request])).toEqual([
      ['W1 is in LP2 slot 1', 'CONFIRM W1 LP2 1'],
      ['LP2 slot 1 is empty', 'CONFIRM LP2 1 EMPTY'],
      ['W1 is on the hand', 'CONFIRM W1 HAND'],
      ['The hand is empty', 'CONFIRM HAND EMPTY'],
      ['W1 is gone (out of the cell)', 'CONFIRM W1 GONE'],
    ]);
    const blade = confirmChoices(report('-', ['hand.B W7']));
    expect(blade.map((x) => x.request)).toEqual(['CONFIRM W7 HAND B', 'CONFIRM HAND B EMPTY', 'CONFIRM W7 GONE']);
  });

  it('says what each does to the map, and that the controller logs it', () => {
    const c = Object.fromEntries(confirmChoices(PUT_CUT).map((x) => [x.id, x.confirm]));
    expect(c['gone-W1']).toBe(
      'CONFIRM W1 GONE removes W1 from the wafer map (it was perhaps at LP2 slot 1 or the hand): it has been taken out of the cell, or it is nowhere to be found. The controller logs it as the operator’s word; nothing moves.',
    );
    expect(c['at-LP2.1']).toBe(
      'CONFIRM W1 LP2 1: your word that W1 is in LP2 slot 1. The wafer map keeps it there, certain, and the hand becomes empty. The controller logs it as the operator’s word; nothing moves.',
    );
    expect(c['empty-hand']).toContain('W1 is no longer thought to be there; it stays uncertain at LP2 slot 1.');
    const alone = Object.fromEntries(confirmChoices(report('-', ['LP2.1 W1'])).map((x) => [x.id, x.confirm]));
    expect(alone['empty-LP2.1']).toContain('W1 was nowhere else, so it leaves the wafer map.');
  });

  it('needs control (NAK 120), but not RESET: an operator may confirm in ERROR', () => {
    expect(recoveryPlan(input()).confirmWhy).toBe('take control first');
    const p = recoveryPlan(input({ owner: 'gui0', holdsControl: true }));
    expect(p.confirmEnabled).toBe(true);
    expect(p.confirms).toHaveLength(5);
    expect(recoveryPlan(input({ ...READY, running: 'SENSE' })).confirmWhy).toBe('SENSE is running');
  });
});

describe('firstReplyView and finalReplyView: the reply the panel shows', () => {
  it('a NAK in red with its code, text and request', () => {
    const nak = { kind: 'NAK', id: 7, code: 140, text: 'the hand may be inside LP2 after an interrupted transfer: RETRACT or HOME first', line: '' } as const;
    expect(firstReplyView('SENSE', nak, false)).toEqual({
      kind: 'nak',
      text: 'NAK 140 the hand may be inside LP2 after an interrupted transfer: RETRACT or HOME first (SENSE)',
    });
  });

  it('an ACK with what it says, running while its INF or ABS is to come', () => {
    const ack = (line: string) => ({ kind: 'ACK', id: 7, fields: {}, line }) as const;
    expect(firstReplyView('RETRACT', ack('ACK 7'), true)).toEqual({ kind: 'ack', text: 'ACK RETRACT (running)' });
    expect(firstReplyView('CONFIRM W1 GONE', ack('ACK 7 W1 is gone (it was at LP2.1 or hand); it left the wafer map*5A'), false)).toEqual({
      kind: 'ack',
      text: 'ACK CONFIRM W1 GONE: W1 is gone (it was at LP2.1 or hand); it left the wafer map',
    });
  });

  it('the end: INF with what it found, ABS in red with its code', () => {
    expect(finalReplyView('SENSE', { kind: 'INF', id: 7, fields: {}, line: 'INF 7 none' })).toEqual({ kind: 'inf', text: 'INF SENSE finished: none' });
    expect(finalReplyView('RETRACT', { kind: 'INF', id: 7, fields: {}, line: 'INF 7' })).toEqual({ kind: 'inf', text: 'INF RETRACT finished' });
    expect(finalReplyView('HOME', { kind: 'ABS', id: 7, code: 201, text: 'emergency stop', line: 'ABS 7 201 emergency stop' })).toEqual({
      kind: 'abs',
      text: 'ABS 201 emergency stop (HOME)',
    });
  });
});
