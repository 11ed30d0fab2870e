import { describe, expect, it } from 'vitest';
import { ORBIT_LIMITS, orbitMove, orbitOf, orbitPosition } from './orbit';

const at = { x: 100, y: 50, z: 200 };

describe('the orbit camera', () => {
  it('orbitOf and orbitPosition are each other\u2019s inverse', () => {
    const pos = { x: 900, y: -700, z: 800 };
    const p = orbitPosition(orbitOf(pos, at));
    expect(p.x).toBeCloseTo(pos.x, 6);
    expect(p.y).toBeCloseTo(pos.y, 6);
    expect(p.z).toBeCloseTo(pos.z, 6);
  });

  it('a drag across the whole view height turns half round; it never goes below the horizon', () => {
    const o = orbitOf({ x: 1100, y: 50, z: 700 }, at);
    const turned = orbitMove(o, 'rotate', 600, 0, 600, 40);
    expect(turned.azimuth).toBeCloseTo(o.azimuth - Math.PI, 9);
    expect(turned.distance).toBe(o.distance);
    expect(orbitMove(o, 'rotate', 0, -10000, 600, 40).polar).toBe(ORBIT_LIMITS.maxPolar);
    expect(orbitMove(o, 'rotate', 0, 10000, 600, 40).polar).toBe(ORBIT_LIMITS.minPolar);
  });

  it('zoom keeps within its distances; pan moves the target, not the distance', () => {
    const o = orbitOf({ x: 1100, y: 50, z: 700 }, at);
    expect(orbitMove(o, 'zoom', 0, 1e6, 600, 40).distance).toBe(ORBIT_LIMITS.maxDistance);
    expect(orbitMove(o, 'zoom', 0, -1e6, 600, 40).distance).toBe(ORBIT_LIMITS.minDistance);
    const panned = orbitMove(o, 'pan', 100, 0, 600, 40);
    expect(panned.distance).toBe(o.distance);
    expect(Math.hypot(panned.target.x - at.x, panned.target.y - at.y, panned.target.z - at.z)).toBeGreaterThan(1);
  });
});
