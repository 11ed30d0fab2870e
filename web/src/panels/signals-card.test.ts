import { describe, expect, it } from 'vitest';
import { guardedSwitch } from './signals-card';

const valve = { n: 0, name: 'vacuum valve' };
const empty = { hand: null, handB: null, handUncertain: false, handBUncertain: false };

describe('switching a guarded output asks first', () => {
  it('names the output, the wafer on the blade and what will happen, and forces it', () => {
    const a = guardedSwitch(valve, false, { ...empty, hand: 'W4' });
    expect(a.title).toBe('Switch off output 0 (vacuum valve)?');
    expect(a.text).toBe(
      'Output 0 (vacuum valve) is guarded. The wafer map says the hand holds W4: it will no longer be held and may drop. The controller logs it as forced, with this page as its source.',
    );
    expect(a.request).toBe('OUT 0 0 FORCE');
    expect(a.danger).toBe(true);
  });

  it('names both blades of a dual-blade robot, and an uncertain wafer as such', () => {
    const a = guardedSwitch(valve, true, { hand: 'W4', handB: 'W7', handUncertain: true, handBUncertain: false });
    expect(a.text).toContain('the hand holds W4? and blade B holds W7');
    expect(a.request).toBe('OUT 0 1 FORCE');
  });

  it('without a wafer on a blade (or without a map) it still asks, and sends without FORCE', () => {
    expect(guardedSwitch(valve, true, empty)).toMatchObject({ request: 'OUT 0 1', danger: false });
    expect(guardedSwitch(valve, false, null).text).toContain('no blade holds a wafer');
  });
});
