// The controller's stations (load ports, aligner, process modules, buffers), drawn in the
// 3D simulator as translucent boxes.
//
// - `STN` is answered with one `EVT STATION <body>` per station (to the requester, before the
//   ACK), then `ACK stations=<n>`. An older controller answers `NAK … 100 unknown verb`: then
//   nothing is drawn and nothing is shown.
// - After `TEACH <name>` the controller sends `EVT STATION <body>` with the new pose to every
//   connection: that station is replaced (or added).
//
// Body: `LP1 kind=load_port x=294.449 y=-170 z=20 yaw=-30 slots=25 pitch=10 approach=220
// stroke=6 speed=30 interlock=14 posture=any` (x, y: centre of a wafer in slot 1 [mm]; z: slot
// 1's support height [mm]; yaw: the direction the hand points into the station [deg]).
//
// A controller that checks motions against the stations adds each one's solid volume: `mouth=
// depth= width= bottom= top= opening=` [mm], in the station's frame (x along its yaw, into the
// station, from the seat): x from -mouth to depth-mouth, y ±width/2, z from bottom to top (the
// Z axis's frame), and the half-width of the open channel the hand enters through. The box is
// then drawn from them; without them, from this module's own sizes. Fixed obstacles come in
// the same reply: `EVT OBSTACLE <name> kind=box x= y= yaw= depth= width= bottom= top=` or
// `kind=cylinder x= y= radius= bottom= top=`.

import type { Bus, Unsubscribe } from '../protocol/bus';
import { Listeners } from '../protocol/listeners';
import type { ObstacleSpec, StationSpec } from '../view3d/scene';
import type { SimulatorHandle } from '../view3d/simulator';

export type StationKind = 'load_port' | 'aligner' | 'process_module' | 'buffer';
export type StationPosture = 'right' | 'left' | 'any';

/** One station, from an `EVT STATION` body. */
export interface StationInfo {
  name: string;
  /** `load_port`, `aligner`, `process_module`, `buffer` (an unknown kind is kept as sent; '' when absent). */
  kind: StationKind | string;
  /** Centre of a wafer seated in slot 1, base frame [mm]. */
  x: number;
  y: number;
  /** Slot 1's support height [mm]. */
  z: number;
  /** Direction the hand points into the station [deg, counter-clockwise from base x]. */
  yaw: number;
  /** Number of slots (slot n at z + (n-1)·pitch). */
  slots: number;
  /** Slot pitch [mm]. */
  pitch: number;
  /** The hand waits this far back along -yaw before entering [mm]. */
  approach: number;
  /** Lift stroke [mm], when given. */
  stroke: number | null;
  /** Entry speed [% or mm/s, as configured], when given. */
  speed: number | null;
  /** Interlock input number, or null (`none` or absent). */
  interlock: number | null;
  posture: StationPosture;
  /** The solid volume the controller checks motions against, when it says it. */
  volume: StationVolume | null;
}

/** A station's solid volume in its own frame [mm] (see the module doc). */
export interface StationVolume {
  mouth: number;
  depth: number;
  width: number;
  bottom: number;
  top: number;
  /** Half-width of the open channel on the mouth face. */
  opening: number;
}

/** A number from a `key=value` value; NaN for an empty or malformed one. */
function num(v: string | undefined): number {
  if (v === undefined || v.trim() === '') return NaN;
  return Number(v);
}

function optNum(v: string | undefined): number | null {
  const n = num(v);
  return Number.isFinite(n) ? n : null;
}

/**
 * Parse one station body (`LP1 kind=load_port x=… y=… z=… yaw=… slots=… pitch=… approach=…`),
 * the text after `EVT STATION `. Unknown keys are ignored. Null when the name or one of
 * x, y, z, yaw, slots, pitch, approach is missing or not a number (slots ≥ 1, pitch ≥ 0).
 * Never throws.
 */
export function parseStationLine(body: string): StationInfo | null {
  if (typeof body !== 'string') return null;
  const tokens = body.trim().split(/\s+/).filter((t) => t !== '');
  const name = tokens[0];
  if (name === undefined || name.includes('=')) return null;
  const f: Record<string, string> = {};
  for (const t of tokens.slice(1)) {
    const eq = t.indexOf('=');
    if (eq <= 0) continue;
    f[t.slice(0, eq).toLowerCase()] = t.slice(eq + 1);
  }
  const x = num(f.x);
  const y = num(f.y);
  const z = num(f.z);
  const yaw = num(f.yaw);
  const slots = num(f.slots);
  const pitch = num(f.pitch);
  const approach = num(f.approach);
  if (![x, y, z, yaw, slots, pitch, approach].every(Number.isFinite)) return null;
  if (slots < 1 || pitch < 0) return null;
  const il = f.interlock;
  const interlock = il === undefined || il.toLowerCase() === 'none' ? null : optNum(il);
  const p = (f.posture ?? '').toLowerCase();
  const posture: StationPosture = p === 'right' || p === 'left' ? p : 'any';
  const vol = ['mouth', 'depth', 'width', 'bottom', 'top', 'opening'].map((k) => num(f[k]));
  const [mouth, vdepth, vwidth, bottom, top, opening] = vol;
  const volume: StationVolume | null =
    vol.every(Number.isFinite) && vdepth > 0 && vwidth > 0 && top > bottom && opening >= 0
      ? { mouth, depth: vdepth, width: vwidth, bottom, top, opening }
      : null;
  return {
    name,
    kind: f.kind ?? '',
    x,
    y,
    z,
    yaw,
    slots: Math.round(slots),
    pitch,
    approach,
    stroke: optNum(f.stroke),
    speed: optNum(f.speed),
    interlock,
    posture,
    volume,
  };
}

/**
 * One `EVT OBSTACLE` body (the text after `OBSTACLE `): `wall kind=box x=0 y=-420 yaw=0
 * depth=900 width=40 bottom=-300 top=400`, `column kind=cylinder x=-300 y=300 radius=60
 * bottom=-300 top=400`. Null when the name, the kind or a size is missing or not a number.
 */
export function parseObstacleLine(body: string): ObstacleSpec | null {
  if (typeof body !== 'string') return null;
  const tokens = body.trim().split(/\s+/).filter((t) => t !== '');
  const name = tokens[0];
  if (name === undefined || name.includes('=')) return null;
  const f: Record<string, string> = {};
  for (const t of tokens.slice(1)) {
    const eq = t.indexOf('=');
    if (eq > 0) f[t.slice(0, eq).toLowerCase()] = t.slice(eq + 1);
  }
  const [x, y, bottom, top] = [f.x, f.y, f.bottom, f.top].map(num);
  if (![x, y, bottom, top].every(Number.isFinite) || top <= bottom) return null;
  if (f.kind === 'box') {
    const [yaw, depth, width] = [f.yaw ?? '0', f.depth, f.width].map(num);
    if (![yaw, depth, width].every(Number.isFinite) || depth <= 0 || width <= 0) return null;
    return { name, kind: 'box', x, y, yaw, depth, width, bottom, top };
  }
  if (f.kind === 'cylinder') {
    const radius = num(f.radius);
    if (!Number.isFinite(radius) || radius <= 0) return null;
    return { name, kind: 'cylinder', x, y, radius, bottom, top };
  }
  return null;
}

// Drawing dimensions [mm].
const WAFER_R = 150; // a 300 mm wafer
const FRONT_GAP = 10; // open side: just in front of the wafer edge, towards the robot
const BACK_GAP = 40; // closed side: beyond the wafer edge, away from the robot
const SIDE_GAP = 20; // each side
const BELOW = 10; // box bottom below slot 1's support
const ABOVE = 20; // added to slots·pitch
const MIN_HEIGHT = 40;

const KIND_COLORS: Record<string, string> = {
  load_port: '#4f86c6',
  aligner: '#c9a13b',
  process_module: '#9b6bc6',
  buffer: '#3f8f8a',
};
const OTHER_COLOR = '#7d8894';

/**
 * The box that holds a station's wafers: a 300 mm wafer fits inside, the open side faces the
 * robot (towards -yaw) and the box reaches further beyond the wafer centre along +yaw; from
 * just below slot 1 to above the top slot.
 */
export function stationSpec(s: StationInfo): StationSpec {
  const v = s.volume;
  const a = (s.yaw * Math.PI) / 180;
  if (v) {
    // The controller's own volume: what motions are checked against.
    const off = v.depth / 2 - v.mouth; // box centre from the seat, along +yaw
    return {
      name: s.name,
      x: s.x + off * Math.cos(a),
      y: s.y + off * Math.sin(a),
      z: v.bottom,
      yaw: s.yaw,
      depth: v.depth,
      width: v.width,
      height: v.top - v.bottom,
      color: KIND_COLORS[s.kind] ?? OTHER_COLOR,
      opening: v.opening,
    };
  }
  const back = WAFER_R + BACK_GAP; // from the wafer centre along +yaw
  const front = WAFER_R + FRONT_GAP; // from the wafer centre along -yaw
  const depth = back + front;
  const off = (back - front) / 2; // box centre from the wafer centre, along +yaw
  return {
    name: s.name,
    x: s.x + off * Math.cos(a),
    y: s.y + off * Math.sin(a),
    z: s.z - BELOW,
    yaw: s.yaw,
    depth,
    width: 2 * (WAFER_R + SIDE_GAP),
    height: Math.max(MIN_HEIGHT, s.slots * s.pitch + ABOVE),
    color: KIND_COLORS[s.kind] ?? OTHER_COLOR,
  };
}

export type StationSink = Pick<SimulatorHandle, 'addStation' | 'removeStation' | 'clearStations'> &
  Partial<Pick<SimulatorHandle, 'setObstacles'>>;

export interface StationsHandle {
  /** The stations drawn, in the order received. */
  stations(): StationInfo[];
  /** Called after the stations drawn changed (a `STN` reply, an `EVT STATION`). */
  onChange(cb: () => void): Unsubscribe;
  /** Ask `STN` again (resolves when its reply has been handled; never rejects). */
  refresh(): Promise<void>;
  dispose(): void;
}

/** Ask the controller for its stations after each connection and draw them in `sim`. */
export function mountStations(bus: Bus, sim: StationSink): StationsHandle {
  const drawn = new Map<string, { info: StationInfo; id: string }>();
  const listeners = new Listeners<[]>('stations');
  let token = 0;
  let disposed = false;

  function changed(): void {
    listeners.emit();
  }

  function upsert(info: StationInfo): void {
    const old = drawn.get(info.name);
    if (old) {
      sim.removeStation(old.id);
      drawn.delete(info.name);
    }
    drawn.set(info.name, { info, id: sim.addStation(stationSpec(info)) });
  }

  function clear(): void {
    if (drawn.size === 0) return;
    sim.clearStations();
    drawn.clear();
  }

  async function refresh(): Promise<void> {
    if (disposed || !bus.connected()) return;
    const mine = ++token;
    let reply: Awaited<ReturnType<Bus['request']>>;
    try {
      reply = await bus.request('STN');
    } catch {
      return; // lost connection or timeout: asked again on the next connection
    }
    if (mine !== token || disposed) return; // a newer STN is on its way
    const { first, events } = reply;
    if (first.kind === 'NAK') {
      // 100: an older controller without stations (draw none). Others: keep what is drawn.
      if (first.code === 100 && drawn.size > 0) {
        clear();
        changed();
      }
      return;
    }
    // Last one wins (an EVT STATION after a TEACH may arrive among the reply's events).
    const list = new Map<string, StationInfo>();
    const obstacles: ObstacleSpec[] = [];
    for (const e of events) {
      const o = /^OBSTACLE[ \t]+(.*)$/i.exec(e);
      if (o) {
        const ob = parseObstacleLine(o[1]);
        if (ob) obstacles.push(ob);
        continue;
      }
      const m = /^STATION[ \t]+(.*)$/i.exec(e);
      const info = m ? parseStationLine(m[1]) : null;
      if (info) list.set(info.name, info);
    }
    sim.setObstacles?.(obstacles);
    sim.clearStations();
    drawn.clear();
    for (const info of list.values()) upsert(info);
    changed();
  }

  const unsubs: Unsubscribe[] = [
    bus.onConnection((up) => {
      if (up) void refresh();
    }),
    bus.onRobot(() => void refresh()),
    bus.onEvent((name, body) => {
      if (disposed || name !== 'STATION') return;
      const info = parseStationLine(body);
      if (info) {
        upsert(info);
        changed();
      }
    }),
  ];
  void refresh();

  return {
    stations: () => [...drawn.values()].map((d) => d.info),
    onChange: (cb) => listeners.add(cb),
    refresh,
    dispose() {
      disposed = true;
      listeners.clear();
      for (const u of unsubs) u();
    },
  };
}
