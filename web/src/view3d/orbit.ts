// The 3D view's camera control: orbit about a target (drag), pan (right or middle drag, or
// Shift-drag) and zoom (wheel), as plain math on the camera's spherical place about its
// target. It runs wherever the scene runs (the page, or the render worker), fed with the
// pointer's movements in CSS pixels.

/** A camera's place about its target: azimuth and polar angle [rad], distance [mm]. */
export interface Orbit {
  target: { x: number; y: number; z: number };
  /** Counter-clockwise from +x, seen from above. */
  azimuth: number;
  /** From +z (straight down) to the camera: 0 above, π/2 level. */
  polar: number;
  distance: number;
}

/** The camera never goes below the horizon, nor closer or farther than these [mm]. */
export const ORBIT_LIMITS = { minPolar: 0.02, maxPolar: Math.PI * 0.495, minDistance: 100, maxDistance: 20000 };

/** The orbit of a camera at `pos` looking at `target`. */
export function orbitOf(pos: { x: number; y: number; z: number }, target: { x: number; y: number; z: number }): Orbit {
  const dx = pos.x - target.x;
  const dy = pos.y - target.y;
  const dz = pos.z - target.z;
  const distance = Math.max(1e-6, Math.hypot(dx, dy, dz));
  return { target: { ...target }, azimuth: Math.atan2(dy, dx), polar: Math.acos(Math.max(-1, Math.min(1, dz / distance))), distance };
}

/** The camera's position for an orbit. */
export function orbitPosition(o: Orbit): { x: number; y: number; z: number } {
  const s = Math.sin(o.polar);
  return {
    x: o.target.x + o.distance * s * Math.cos(o.azimuth),
    y: o.target.y + o.distance * s * Math.sin(o.azimuth),
    z: o.target.z + o.distance * Math.cos(o.polar),
  };
}

/**
 * The orbit after a pointer movement of (dx, dy) CSS pixels in a view `height` pixels high
 * with a vertical field of view `fovDeg`: `rotate` turns about the target (a full view height
 * is a half turn), `pan` moves the target with the view's plane, `zoom` (dy only: wheel
 * pixels) moves closer or farther.
 */
export function orbitMove(o: Orbit, kind: 'rotate' | 'pan' | 'zoom', dx: number, dy: number, height: number, fovDeg: number): Orbit {
  const h = Math.max(1, height);
  const L = ORBIT_LIMITS;
  if (kind === 'rotate') {
    const polar = Math.min(L.maxPolar, Math.max(L.minPolar, o.polar - (Math.PI * dy) / h));
    return { ...o, azimuth: o.azimuth - (Math.PI * dx) / h, polar };
  }
  if (kind === 'zoom') {
    const distance = Math.min(L.maxDistance, Math.max(L.minDistance, o.distance * Math.exp(dy * 0.001)));
    return { ...o, distance };
  }
  // Pan: the view's right and up directions, scaled so the point under the pointer follows it.
  const perPixel = (2 * o.distance * Math.tan(((fovDeg / 2) * Math.PI) / 180)) / h;
  const rx = -Math.sin(o.azimuth);
  const ry = Math.cos(o.azimuth);
  // Up in the view plane: towards the target from below, tilted by the polar angle.
  const ux = -Math.cos(o.polar) * Math.cos(o.azimuth);
  const uy = -Math.cos(o.polar) * Math.sin(o.azimuth);
  const uz = Math.sin(o.polar);
  const mx = -dx * perPixel;
  const my = dy * perPixel;
  return {
    ...o,
    target: { x: o.target.x + rx * mx + ux * my, y: o.target.y + ry * mx + uy * my, z: o.target.z + uz * my },
  };
}
