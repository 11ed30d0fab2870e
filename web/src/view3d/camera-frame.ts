// The 3D view's default camera: it frames the robot and the station it works at (the one of
// the transfer in progress, else the one nearest the hand), seen from the side from which
// fewest other stations stand in the line of sight, so that no cassette hides the hand. Pure
// plan-view geometry [mm, deg], unit-tested; scene.ts places the camera.

/** A station's footprint in plan view: a rectangle centred at (x, y), rotated by `yaw`. */
export interface Footprint {
  name: string;
  x: number;
  y: number;
  yaw: number;
  /** Along the rectangle's own x and y [mm]. */
  depth: number;
  width: number;
}

export interface CameraFrame {
  /** The point the camera looks at, in plan view [mm]. */
  target: { x: number; y: number };
  /** The direction from the target to the camera in plan view [deg, counter-clockwise from x]. */
  azimuth: number;
  /** How far the framed things reach from the target [mm] (the camera backs off to show it). */
  radius: number;
  /** The station framed, or null (no stations: the robot alone). */
  station: string | null;
}

/** Azimuths tried, every 15°. */
const STEP_DEG = 15;

/** Whether the segment a→b crosses the rectangle `f` (or starts inside it). */
export function segmentHitsFootprint(a: { x: number; y: number }, b: { x: number; y: number }, f: Footprint): boolean {
  const r = (-f.yaw * Math.PI) / 180;
  const toLocal = (p: { x: number; y: number }): [number, number] => {
    const dx = p.x - f.x;
    const dy = p.y - f.y;
    return [dx * Math.cos(r) - dy * Math.sin(r), dx * Math.sin(r) + dy * Math.cos(r)];
  };
  const [ax, ay] = toLocal(a);
  const [bx, by] = toLocal(b);
  const hx = f.depth / 2;
  const hy = f.width / 2;
  // Liang-Barsky clipping of the segment against the box.
  let t0 = 0;
  let t1 = 1;
  const dx = bx - ax;
  const dy = by - ay;
  const clip = (p: number, q: number): boolean => {
    if (p === 0) return q >= 0;
    const t = q / p;
    if (p < 0) {
      if (t > t1) return false;
      if (t > t0) t0 = t;
    } else {
      if (t < t0) return false;
      if (t < t1) t1 = t;
    }
    return true;
  };
  return clip(-dx, ax + hx) && clip(dx, hx - ax) && clip(-dy, ay + hy) && clip(dy, hy - ay) && t0 <= t1;
}

/**
 * The camera's frame for the robot at the origin with `stations`, the hand at `hand` (plan
 * view), and the station of the transfer in progress (`working`, null: none).
 */
export function frameCamera(
  stations: readonly Footprint[],
  hand: { x: number; y: number } | null,
  working: string | null,
  reach: number,
): CameraFrame {
  const byName = working ? stations.find((s) => s.name === working) : undefined;
  const near =
    byName ??
    (hand && stations.length > 0
      ? stations.reduce((best, s) => (Math.hypot(s.x - hand.x, s.y - hand.y) < Math.hypot(best.x - hand.x, best.y - hand.y) ? s : best))
      : stations[0]);
  if (!near) return { target: { x: 0, y: 0 }, azimuth: -50, radius: Math.max(400, reach), station: null };
  const target = { x: near.x / 2, y: near.y / 2 };
  const half = Math.hypot(near.x, near.y) / 2;
  const radius = Math.max(400, half + Math.max(near.depth, near.width) / 2 + 80);
  const toStation = (Math.atan2(near.y, near.x) * 180) / Math.PI;
  const others = stations.filter((s) => s !== near);
  const look = [target, { x: near.x, y: near.y }, { x: 0, y: 0 }, ...(hand ? [hand] : [])];
  let best = { azimuth: toStation - 90, blocked: Infinity, off: Infinity };
  for (let k = 0; k < 360 / STEP_DEG; k++) {
    const azimuth = k * STEP_DEG;
    const a = (azimuth * Math.PI) / 180;
    const eye = { x: target.x + Math.cos(a) * radius * 2.5, y: target.y + Math.sin(a) * radius * 2.5 };
    let blocked = 0;
    for (const o of others) for (const p of look) if (segmentHitsFootprint(eye, p, o)) blocked++;
    // Among equally clear views, the one most square to the robot-station line (both seen side by side).
    const off = Math.abs(Math.abs(((azimuth - toStation + 540) % 360) - 180) - 90);
    if (blocked < best.blocked || (blocked === best.blocked && off < best.off)) best = { azimuth, blocked, off };
  }
  return { target, azimuth: best.azimuth, radius, station: near.name };
}
