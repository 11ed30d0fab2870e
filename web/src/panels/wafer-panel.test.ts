import { describe, expect, it } from 'vitest';
import {
  actionsHint,
  bladeText,
  isDualBlade,
  keepSelection,
  pendingText,
  slotLabel,
  slotTitle,
  waferActions,
  type WaferSelection,
} from './wafer-panel';
import { emptyWaferMap, parseWafersBody, type WaferState } from '../cell/wafers';

function state(body: string, available: boolean | null = true): WaferState {
  return { available, map: parseWafersBody(body).map, refusal: '', ignored: [] };
}

const MAP = 'hand=- LP1=W1,-,?,D,X LP2=-x3 AL=W9';
const sel = (station: string, slot: number | null = null): WaferSelection => ({ station, slot });
const ready = { connected: true, mayCommand: true };

describe('slotLabel and slotTitle', () => {
  it('show each state', () => {
    const m = state(MAP).map.stations.get('LP1')!;
    expect(m.map(slotLabel)).toEqual(['W1', '', '?', 'double', 'cross']);
    expect(slotTitle('LP1', 1, m[0])).toBe('LP1 slot 1: W1');
    expect(slotTitle('LP1', 3, m[2])).toBe('LP1 slot 3: not mapped yet');
    expect(slotTitle('LP1', 4, m[3])).toMatch(/double wafer/);
  });
});

describe('an uncertain place', () => {
  const UNCERTAIN = 'hand=W1? LP1=-,W2..W25 LP2=W1?,-x24';

  it('shows W<n>? in its slot and on the hand, and says what it means', () => {
    const slot = state(UNCERTAIN).map.stations.get('LP2')![0];
    expect(slotLabel(slot)).toBe('W1?');
    expect(slotTitle('LP2', 1, slot)).toBe(
      'LP2 slot 1: perhaps W1, perhaps empty (uncertain after an interrupted transfer: MAP LP2 or CONFIRM it)',
    );
    expect(bladeText('W1', true)).toBe('W1? (uncertain: perhaps on the blade; SENSE or CONFIRM it)');
    expect(bladeText('W1', false)).toBe('W1');
    expect(bladeText(null, false)).toBe('empty');
  });

  it('is neither taken from nor put into (NAK 139), but may be mapped', () => {
    const s = state(UNCERTAIN.replace('hand=W1?', 'hand=-'));
    const a = waferActions({ ...ready, state: s, selection: sel('LP2', 1) });
    expect(a.get.why).toBe('LP2 slot 1 is uncertain (perhaps W1): MAP LP2 or CONFIRM it first');
    expect(a.map).toEqual({ enabled: true, request: 'MAP LP2', why: '' });
    const b = waferActions({ ...ready, state: state(UNCERTAIN.replace('hand=W1?', 'hand=W9')), selection: sel('LP2', 1) });
    expect(b.put.why).toBe('LP2 slot 1 is uncertain (perhaps W1): MAP LP2 or CONFIRM it first');
  });

  it('on the hand: no GET onto it and no PUT from it until SENSE or CONFIRM', () => {
    const a = waferActions({ ...ready, state: state(UNCERTAIN), selection: sel('LP2', 2) });
    expect(a.get.why).toBe('the hand may hold W1 (uncertain): SENSE or CONFIRM it first');
    expect(a.put.why).toBe('the hand may hold W1 (uncertain): SENSE or CONFIRM it first');
    const dual = waferActions({
      ...ready,
      dualBlade: true,
      state: state('hand=- hand.B=W7? PM1=W5'),
      selection: sel('PM1', 1),
    });
    expect(dual.swap?.why).toBe('blade B may hold W7 (uncertain): SENSE or CONFIRM it first');
  });
});

describe('keepSelection', () => {
  it('drops a station that is gone and a slot beyond the new count', () => {
    const m = state(MAP).map;
    expect(keepSelection(m, null)).toBeNull();
    expect(keepSelection(m, sel('LP1', 5))).toEqual(sel('LP1', 5));
    expect(keepSelection(m, sel('LP2', 4))).toEqual(sel('LP2'));
    expect(keepSelection(m, sel('PM9', 1))).toBeNull();
  });
});

describe('waferActions', () => {
  it('GET from a slot with a wafer while the hand is empty; MAP the station', () => {
    const a = waferActions({ ...ready, state: state(MAP), selection: sel('LP1', 1) });
    expect(a.get).toEqual({ enabled: true, request: 'GET LP1 1', why: '' });
    expect(a.put.enabled).toBe(false);
    expect(a.put.request).toBe('PUT LP1 1');
    expect(a.put.why).toBe('the hand holds no wafer');
    expect(a.map).toEqual({ enabled: true, request: 'MAP LP1', why: '' });
  });

  it('PUT into an empty slot while the hand holds a wafer', () => {
    const s = state(MAP.replace('hand=-', 'hand=W7'));
    const a = waferActions({ ...ready, state: s, selection: sel('LP2', 2) });
    expect(a.put).toEqual({ enabled: true, request: 'PUT LP2 2', why: '' });
    expect(a.get.why).toBe('the hand already holds W7');
    expect(waferActions({ ...ready, state: s, selection: sel('AL', 1) }).put.why).toBe('AL slot 1 holds W9');
  });

  it('says why a slot cannot be used', () => {
    const why = (slot: number, hand = '-') =>
      waferActions({ ...ready, state: state(MAP.replace('hand=-', `hand=${hand}`)), selection: sel('LP1', slot) });
    expect(why(2).get.why).toBe('LP1 slot 2 is empty');
    expect(why(3).get.why).toBe('LP1 slot 3 is not mapped yet: MAP LP1 first');
    expect(why(3, 'W7').put.why).toBe('LP1 slot 3 is not mapped yet: MAP LP1 first');
    expect(why(4).get.why).toMatch(/^LP1 slot 4 holds a double wafer .*: clear it and MAP LP1$/);
    expect(why(5, 'W7').put.why).toMatch(/^LP1 slot 5 holds a cross-slotted wafer/);
    expect(why(3).map.enabled).toBe(true); // mapping is how an unknown slot becomes known
  });

  it('needs a slot for GET/PUT and a station for MAP', () => {
    const none = waferActions({ ...ready, state: state(MAP), selection: null });
    expect(none.get).toEqual({ enabled: false, request: null, why: 'select a slot' });
    expect(none.map).toEqual({ enabled: false, request: null, why: 'select a station to map' });
    const station = waferActions({ ...ready, state: state(MAP), selection: sel('LP2') });
    expect(station.get.enabled).toBe(false);
    expect(station.map.enabled).toBe(true);
    expect(waferActions({ ...ready, state: state(MAP), selection: sel('PM9', 1) }).map.enabled).toBe(false);
  });

  it('disables everything, with one reason, when not connected, not in control, without a map or during a transfer', () => {
    const cases: [Parameters<typeof waferActions>[0], string][] = [
      [{ connected: false, mayCommand: true, state: state(MAP), selection: sel('LP1', 1) }, 'not connected to the controller'],
      [{ ...ready, state: state('', false), selection: sel('LP1', 1) }, 'this controller has no wafer cell'],
      [{ ...ready, state: state('', null), selection: sel('LP1', 1) }, 'waiting for the wafer map (WAFERS)'],
      [{ connected: true, mayCommand: false, state: state(MAP), selection: sel('LP1', 1) }, 'control is held by another source; take control first'],
      [{ ...ready, state: state(`${MAP} pending=get:LP1.1:W1`), selection: sel('LP1', 1) }, 'a transfer is in progress (GET LP1.1 W1)'],
      [{ ...ready, state: state(MAP), selection: sel('LP1', 1), running: 'MAP LP1' }, 'MAP LP1 is running'],
    ];
    for (const [input, why] of cases) {
      const a = waferActions(input);
      for (const k of ['get', 'put', 'map'] as const) {
        expect(a[k].enabled, `${why}: ${k}`).toBe(false);
        expect(a[k].why).toBe(why);
      }
      expect(a.get.request).toBe('GET LP1 1'); // the button still names what it would send
      expect(actionsHint(a)).toBe(why);
    }
  });
});

describe('a single-hand robot', () => {
  it('has no SWAP and ignores a blade B choice: its requests stay as they were', () => {
    const a = waferActions({ ...ready, state: state(MAP), selection: sel('LP1', 1), blade: 'B' });
    expect(a.swap).toBeNull();
    expect(a.get).toEqual({ enabled: true, request: 'GET LP1 1', why: '' });
    expect(a.put.request).toBe('PUT LP1 1');
  });
});

describe('a dual-blade robot', () => {
  const DUAL = 'hand=- hand.B=- LP1=W1,-,?,D PM1=W5';
  const dual = { ...ready, dualBlade: true };
  const dstate = (hand: string, handB: string) => state(DUAL.replace('hand=-', `hand=${hand}`).replace('hand.B=-', `hand.B=${handB}`));

  it('is known from blade_b= of ROBOT, or from a wafer on blade B', () => {
    const empty = emptyWaferMap();
    expect(isDualBlade({ bladeB: -30 }, empty)).toBe(true);
    expect(isDualBlade({ bladeB: 0 }, empty)).toBe(true);
    expect(isDualBlade({ bladeB: null }, empty)).toBe(false);
    expect(isDualBlade({}, empty)).toBe(false);
    expect(isDualBlade(null, empty)).toBe(false);
    expect(isDualBlade(null, { ...empty, handB: 'W7' })).toBe(true);
  });

  it('GETs and PUTs with blade A as before, and with blade B adding " B"', () => {
    const a = waferActions({ ...dual, state: dstate('-', '-'), selection: sel('LP1', 1) });
    expect(a.get).toEqual({ enabled: true, request: 'GET LP1 1', why: '' });
    const b = waferActions({ ...dual, state: dstate('-', '-'), selection: sel('LP1', 1), blade: 'B' });
    expect(b.get).toEqual({ enabled: true, request: 'GET LP1 1 B', why: '' });
    expect(b.put).toEqual({ enabled: false, request: 'PUT LP1 1 B', why: 'blade B holds no wafer' });
    const c = waferActions({ ...dual, state: dstate('W2', 'W7'), selection: sel('LP1', 2), blade: 'B' });
    expect(c.put).toEqual({ enabled: true, request: 'PUT LP1 2 B', why: '' });
    expect(waferActions({ ...dual, state: dstate('-', 'W7'), selection: sel('LP1', 1), blade: 'B' }).get.why).toBe(
      'blade B already holds W7',
    );
  });

  it('each blade is checked on its own: blade A loaded does not stop a GET with blade B', () => {
    const a = waferActions({ ...dual, state: dstate('W2', '-'), selection: sel('LP1', 1), blade: 'B' });
    expect(a.get.enabled).toBe(true);
    const b = waferActions({ ...dual, state: dstate('W2', '-'), selection: sel('LP1', 1), blade: 'A' });
    expect(b.get.why).toBe('the hand already holds W2');
  });

  it('SWAPs when exactly one blade holds a wafer and the slot holds one', () => {
    for (const [hand, handB] of [
      ['W2', '-'],
      ['-', 'W7'],
    ]) {
      const a = waferActions({ ...dual, state: dstate(hand, handB), selection: sel('PM1', 1) });
      expect(a.swap, `${hand} ${handB}`).toEqual({ enabled: true, request: 'SWAP PM1 1', why: '' });
    }
    // The blade choice is not part of SWAP: the controller takes with the empty blade.
    expect(waferActions({ ...dual, state: dstate('W2', '-'), selection: sel('PM1', 1), blade: 'B' }).swap?.request).toBe('SWAP PM1 1');
  });

  it('says why SWAP cannot be pressed', () => {
    const why = (hand: string, handB: string, slot: number) =>
      waferActions({ ...dual, state: dstate(hand, handB), selection: sel('LP1', slot) }).swap?.why;
    expect(why('-', '-', 1)).toBe('neither blade holds a wafer to swap in');
    expect(why('W2', 'W7', 1)).toBe('both blades hold a wafer (W2, W7): SWAP needs one empty');
    expect(why('W2', '-', 2)).toBe('LP1 slot 2 is empty');
    expect(why('W2', '-', 3)).toBe('LP1 slot 3 is not mapped yet: MAP LP1 first');
    expect(why('-', 'W7', 4)).toMatch(/^LP1 slot 4 holds a double wafer/);
    expect(why('W2', '-', 9)).toBe('LP1 slot 9 does not exist');
    const none = waferActions({ ...dual, state: dstate('W2', '-'), selection: sel('LP1') });
    expect(none.swap).toEqual({ enabled: false, request: null, why: 'select a slot' });
  });

  it('disables SWAP with the others, for the same reason', () => {
    const a = waferActions({ ...dual, state: state(`${DUAL} pending=get:PM1.1:W5:B`), selection: sel('PM1', 1) });
    expect(a.swap).toEqual({ enabled: false, request: 'SWAP PM1 1', why: 'a transfer is in progress (GET PM1.1 W5 with blade B)' });
    expect(actionsHint(a)).toBe('a transfer is in progress (GET PM1.1 W5 with blade B)');
    const b = waferActions({ ...dual, state: dstate('W2', '-'), selection: sel('PM1', 1), running: 'SWAP PM1 1' });
    expect(b.swap?.why).toBe('SWAP PM1 1 is running');
  });

  it('lists SWAP in the hint only where it has a button', () => {
    const a = waferActions({ ...dual, state: dstate('-', '-'), selection: sel('PM1', 1) });
    expect(actionsHint(a)).toBe('PUT: the hand holds no wafer · SWAP: neither blade holds a wafer to swap in');
    const b = waferActions({ ...dual, state: dstate('-', '-'), selection: null });
    expect(actionsHint(b)).toBe('GET: select a slot · PUT: select a slot · MAP: select a station to map · SWAP: select a slot');
  });
});

describe('pendingText', () => {
  it('names the transfer and blade B when it makes it', () => {
    expect(pendingText(null)).toBe('no transfer');
    const p = state('hand=- LP1=W1 pending=get:LP1.1:W1').map.pending;
    expect(pendingText(p)).toBe('GET LP1 slot 1 (W1) in progress');
    const q = state('hand=- LP1=- pending=put:LP1.1:W7:B').map.pending;
    expect(pendingText(q)).toBe('PUT LP1 slot 1 (W7) with blade B in progress');
  });
});

describe('actionsHint', () => {
  it('lists each disabled button with its reason, or nothing', () => {
    const a = waferActions({ ...ready, state: state(MAP), selection: sel('LP1', 1) });
    expect(actionsHint(a)).toBe('PUT: the hand holds no wafer');
    const b = waferActions({ ...ready, state: state(MAP), selection: null });
    expect(actionsHint(b)).toBe('GET: select a slot · PUT: select a slot · MAP: select a station to map');
    const c = waferActions({ ...ready, state: state(MAP.replace('hand=-', 'hand=W7')), selection: sel('LP2', 1) });
    expect(actionsHint(c)).toBe('GET: the hand already holds W7');
  });
});

describe('a running program', () => {
  it('disables GET, PUT and MAP with what to do first (the controller answers 127)', () => {
    const why = 'wafer_cycle is paused: CONTINUE or ABORT it (Editor) first';
    const a = waferActions({ ...ready, state: state(MAP), selection: sel('LP1', 1), program: why });
    expect([a.get, a.put, a.map].map((x) => x.why)).toEqual([why, why, why]);
    expect(waferActions({ ...ready, state: state(MAP), selection: sel('LP1', 1), program: '' }).get.enabled).toBe(true);
  });
});
