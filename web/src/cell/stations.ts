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

import type { Bus, Unsubscribe } from '../protocol/bus';
import { Listeners } from '../protocol/listeners';
import type { StationSpec } from '../view3d/scene';
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
  };
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
  const back = WAFER_R + BACK_GAP; // from the wafer centre along +yaw
  const front = WAFER_R + FRONT_GAP; // from the wafer centre along -yaw
  const depth = back + front;
  const off = (back - front) / 2; // box centre from the wafer centre, along +yaw
  const a = (s.yaw * Math.PI) / 180;
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

export type StationSink = Pick<SimulatorHandle, 'addStation' | 'removeStation' | 'clearStations'>;

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
    for (const e of events) {
      const m = /^STATION[ \t]+(.*)$/i.exec(e);
      const info = m ? parseStationLine(m[1]) : null;
      if (info) list.set(info.name, info);
    }
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
