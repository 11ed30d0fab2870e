// The wafer map (docs/protocol.md, "Stations and wafers"): where every wafer is, as the
// controller reports it, and the `WaferStore` that keeps it up to date for the Wafers panel
// and the 3D view.
//
// - `WAFERS` is answered `ACK <id> hand=<tok> [hand.B=<tok>] <STN>=<slots> … [pending=…]`, or, when that does
//   not fit in one line, with one `EVT WAFER <part>` line per place (to the requester, before
//   the ACK) and `ACK <id> parts=<n>`. A controller without a cell answers `NAK`.
// - Whenever the map changes, every connection gets `EVT WAFER <part>` for each place that
//   changed (`hand=W3`, `LP1=W1,W2,-,W4..W25`, `pending=get:LP1.3:W3`, `pending=-`).
// - A dual-blade robot has a second blade B on the same wrist: `hand` is still the hand
//   (blade A), `hand.B=<tok>` is blade B (listed only by a dual-blade robot), and a transfer
//   blade B makes ends with `:B` (`pending=get:PM1.1:W7:B`).
// - Slots are listed from slot 1 up, comma-separated: `W<n>` a wafer, `-` empty, `?` not mapped,
//   `D` double, `X` cross-slotted, `W<n>?` uncertain (perhaps that wafer, perhaps nothing,
//   after a transfer a power loss interrupted; never part of a run); `W<a>..W<b>` three or
//   more wafers with rising ids in successive slots; `<tok>x<n>` a token repeated n times
//   (`?x25`).
// - The same id may be uncertain in two places at once (`hand=W1?` and `LP2=W1?,-x24`): the
//   wafer is in one of them, or in neither. RECOVERY (recovery.ts) says what happened.
//
// Parsing never throws: a malformed part is left out (and reported in `bad`), the rest is used.

import type { Bus, FirstReply, Unsubscribe } from '../protocol/bus';
import { Listeners } from '../protocol/listeners';
import type { WaferDisc } from '../view3d/scene';
import type { SimulatorHandle } from '../view3d/simulator';
import type { StationInfo, StationsHandle } from './stations';

/**
 * What a slot holds. `uncertain`: perhaps the wafer named, perhaps nothing (GET and PUT are
 * refused until a MAP or an operator's CONFIRM settles it).
 */
export type SlotState = 'wafer' | 'empty' | 'unknown' | 'double' | 'cross' | 'uncertain';

/** One slot of a station (or the hand): its state and, for `wafer` and `uncertain`, the wafer's id (`W3`). */
export interface SlotToken {
  state: SlotState;
  /** `W<n>` when `state` is `wafer` or `uncertain`, otherwise null. */
  wafer: string | null;
}

/** Blade A is the hand (the TCP's blade); B a dual-blade robot's second blade. */
export type Blade = 'A' | 'B';

/** A transfer the controller has begun and not yet committed (`pending=get:LP1.3:W3[:B]`). */
export interface PendingTransfer {
  kind: 'get' | 'put';
  /** The blade that takes or gives the wafer (`A` when the controller names none). */
  blade: Blade;
  station: string;
  /** 1-based slot number. */
  slot: number;
  /** The wafer being moved (`W3`). */
  wafer: string;
}

/** Where every wafer is. Treated as immutable: every change makes a new object. */
export interface WaferMap {
  /** The wafer on the hand (blade A, `W3`), or null when the hand is empty. */
  hand: string | null;
  /** The wafer on blade B of a dual-blade robot, or null when it is empty or there is none. */
  handB: string | null;
  /**
   * The wafer on the hand (blade A) is uncertain (`hand=W3?`): perhaps there, perhaps not
   * (the motion board stopped answering while it was there, or a power loss switched its
   * vacuum off), until a sensor or an operator settles it.
   */
  handUncertain: boolean;
  /** The same for blade B (`hand.B=W7?`). */
  handBUncertain: boolean;
  /** Each station's slots, slot 1 first, in the order the controller lists them. */
  stations: Map<string, SlotToken[]>;
  pending: PendingTransfer | null;
}

/** One place of the map, as in one word of the `WAFERS` reply or one `EVT WAFER` line. */
export type WaferPart =
  | { place: 'hand'; wafer: string | null; uncertain: boolean }
  | { place: 'handB'; wafer: string | null; uncertain: boolean }
  | { place: 'pending'; pending: PendingTransfer | null }
  | { place: 'station'; name: string; slots: SlotToken[] };

/** The most slots a station can have (wrc-cell's `MAX_SLOTS`); a longer list is malformed. */
export const MAX_SLOTS = 50;

const EMPTY: SlotToken = { state: 'empty', wafer: null };
const UNKNOWN: SlotToken = { state: 'unknown', wafer: null };
const DOUBLE: SlotToken = { state: 'double', wafer: null };
const CROSS: SlotToken = { state: 'cross', wafer: null };

/** An empty map: no stations, nothing on either blade, no transfer. */
export function emptyWaferMap(): WaferMap {
  return { hand: null, handB: null, handUncertain: false, handBUncertain: false, stations: new Map(), pending: null };
}

/** The number of a wafer id `W<n>` (or `w<n>`), or null. */
function waferNumber(tok: string): number | null {
  const m = /^[Ww](\d{1,10})$/.exec(tok);
  if (!m) return null;
  const n = Number(m[1]);
  return n <= 0xffff_ffff ? n : null;
}

/** A wafer id as the controller writes it (`W3`; `w03` → `W3`), or null when it is none. */
export function parseWaferId(tok: string): string | null {
  const n = waferNumber(tok);
  return n === null ? null : `W${n}`;
}

/** One uncompressed slot token (`W3`, `-`, `?`, `D`, `X`, `W3?`), or null. */
function slotToken(tok: string): SlotToken | null {
  switch (tok) {
    case '-':
      return EMPTY;
    case '?':
      return UNKNOWN;
    case 'D':
      return DOUBLE;
    case 'X':
      return CROSS;
    default: {
      const uncertain = tok.endsWith('?');
      const w = parseWaferId(uncertain ? tok.slice(0, -1) : tok);
      if (w === null) return null;
      return { state: uncertain ? 'uncertain' : 'wafer', wafer: w };
    }
  }
}

/**
 * A station's slots (`W1,W2,-,W4..W25`, `?x25`, `W1?,-x24`), expanded to one token per slot, slot 1
 * first. Null when any item is malformed, when a run goes down (`W5..W3`) or when the list
 * has more than `MAX_SLOTS` slots.
 */
export function parseSlots(text: string): SlotToken[] | null {
  if (typeof text !== 'string' || text === '') return null;
  const out: SlotToken[] = [];
  for (const item of text.split(',')) {
    const run = /^([Ww]\d+)\.\.([Ww]\d+)$/.exec(item);
    if (run) {
      const a = waferNumber(run[1]);
      const b = waferNumber(run[2]);
      if (a === null || b === null || b < a || out.length + (b - a + 1) > MAX_SLOTS) return null;
      for (let n = a; n <= b; n++) out.push({ state: 'wafer', wafer: `W${n}` });
      continue;
    }
    const rep = /^(.+)x(\d{1,3})$/.exec(item);
    if (rep) {
      const t = slotToken(rep[1]);
      const n = Number(rep[2]);
      if (t === null || n < 1 || out.length + n > MAX_SLOTS) return null;
      for (let i = 0; i < n; i++) out.push(t);
      continue;
    }
    const t = slotToken(item);
    if (t === null || out.length + 1 > MAX_SLOTS) return null;
    out.push(t);
  }
  return out;
}

/**
 * `get:LP1.3:W3`, or `get:LP1.3:W3:B` when blade B makes it (the value of `pending=`); `-` is
 * no transfer (undefined: malformed).
 */
function parsePending(v: string): PendingTransfer | null | undefined {
  if (v === '-') return null;
  const m = /^(get|put):([^\s=:,.]+)\.(\d{1,3}):([Ww]\d+)(?::([AaBb]))?$/.exec(v);
  if (!m) return undefined;
  const wafer = parseWaferId(m[4]);
  const slot = Number(m[3]);
  if (wafer === null || slot < 1) return undefined;
  const blade: Blade = m[5]?.toUpperCase() === 'B' ? 'B' : 'A';
  return { kind: m[1].toLowerCase() as 'get' | 'put', blade, station: m[2], slot, wafer };
}

/**
 * The wafer on a blade (`W3`, `W3?` while uncertain, or `-` for none); undefined when
 * malformed.
 */
function parseBlade(value: string): { wafer: string | null; uncertain: boolean } | undefined {
  if (value === '-') return { wafer: null, uncertain: false };
  const uncertain = value.endsWith('?');
  const wafer = parseWaferId(uncertain ? value.slice(0, -1) : value);
  return wafer === null ? undefined : { wafer, uncertain };
}

/**
 * One place of the map: `hand=W3`, `hand=W3?` (uncertain), `hand=-`, `hand.B=W7`, `LP1=W1..W25`,
 * `pending=get:LP1.3:W3[:B]`, `pending=-`. A leading `WAFER ` (an event line without its `EVT `) is skipped. Null when
 * malformed.
 */
export function parseWaferPart(text: string): WaferPart | null {
  if (typeof text !== 'string') return null;
  const t = text.trim().replace(/^WAFER[ \t]+/i, '');
  const eq = t.indexOf('=');
  if (eq <= 0 || /\s/.test(t)) return null;
  const key = t.slice(0, eq);
  const value = t.slice(eq + 1);
  if (key === 'hand' || key === 'hand.B') {
    const w = parseBlade(value);
    if (w === undefined) return null;
    return key === 'hand' ? { place: 'hand', ...w } : { place: 'handB', ...w };
  }
  if (key === 'pending') {
    const p = parsePending(value);
    return p === undefined ? null : { place: 'pending', pending: p };
  }
  if (!/^[^\s=:,.]+$/.test(key)) return null;
  const slots = parseSlots(value);
  return slots === null ? null : { place: 'station', name: key, slots };
}

/** The map with one place replaced (a station not yet in the map is added at the end). */
export function applyWaferPart(map: WaferMap, part: WaferPart): WaferMap {
  switch (part.place) {
    case 'hand':
      return { ...map, hand: part.wafer, handUncertain: part.uncertain };
    case 'handB':
      return { ...map, handB: part.wafer, handBUncertain: part.uncertain };
    case 'pending':
      return { ...map, pending: part.pending };
    case 'station': {
      const stations = new Map(map.stations);
      stations.set(part.name, part.slots);
      return { ...map, stations };
    }
  }
}

/** A map built from parts in order; malformed parts are listed in `bad`. */
function fromParts(parts: readonly string[]): { map: WaferMap; bad: string[] } {
  let map = emptyWaferMap();
  const bad: string[] = [];
  for (const p of parts) {
    const part = parseWaferPart(p);
    if (part) map = applyWaferPart(map, part);
    else bad.push(p);
  }
  return { map, bad };
}

/**
 * The body of a one-line `WAFERS` reply (after `ACK <id>`): `hand=W3 [hand.B=-] LP1=W1,W2,-,W4..W25 …`.
 * A place that is not listed stays empty (no wafer on either blade, no transfer pending).
 */
export function parseWafersBody(body: string): { map: WaferMap; bad: string[] } {
  const words = (typeof body === 'string' ? body : '').split(/[ \t]+/).filter((w) => w !== '' && !/^parts=/.test(w));
  return fromParts(words);
}

/**
 * The map from a `WAFERS` reply: its ACK line (`ACK 3 hand=- LP1=?x25 …` or `ACK 3 parts=7`)
 * and the event lines collected before it (without `EVT `; only `WAFER …` lines are used).
 * With `parts=<n>` the map is the last n `WAFER` lines (the controller sends the reply's
 * parts right before its ACK; a broadcast change that came earlier is older than them).
 * `bad` lists malformed parts, and says so when fewer than n parts came.
 */
export function wafersFromReply(ackLine: string, events: readonly string[]): { map: WaferMap; bad: string[] } {
  const body = (typeof ackLine === 'string' ? ackLine : '')
    .replace(/\*[0-9A-Fa-f]{2}\s*$/, '')
    .replace(/^\s*ACK(?:[ \t]+\d+)?(?=[ \t]|$)/i, '')
    .trim();
  const m = /(?:^|[ \t])parts=(\d+)(?:[ \t]|$)/.exec(body);
  if (!m) return parseWafersBody(body);
  const n = Number(m[1]);
  const lines = events.filter((e) => /^WAFER[ \t]/i.test(e));
  const got = lines.slice(Math.max(0, lines.length - n));
  const r = fromParts(got);
  if (got.length < n) r.bad.push(`parts=${n} but ${got.length} EVT WAFER line${got.length === 1 ? '' : 's'} came`);
  return r;
}

/** Whether any place of the map is uncertain (a slot `W3?`, or a blade). */
export function hasUncertain(map: WaferMap): boolean {
  if (map.handUncertain || map.handBUncertain) return true;
  for (const slots of map.stations.values()) if (slots.some((t) => t.state === 'uncertain')) return true;
  return false;
}

/** `GET LP1.3 W3` for a pending transfer; `GET LP1.3 W3 with blade B` when blade B makes it. */
export function formatPending(p: PendingTransfer): string {
  const s = `${p.kind.toUpperCase()} ${p.station}.${p.slot} ${p.wafer}`;
  return p.blade === 'B' ? `${s} with blade B` : s;
}

// ---------------------------------------------------------------------------------------------
// The 3D view's wafers

/** Smallest drawn tilt of a cross-slotted wafer [deg], so that it shows with a fine pitch. */
const MIN_CROSS_TILT_DEG = 3;
const WAFER_DIAMETER = 300;

/**
 * The wafers to draw in the stations: one disc per slot that holds a wafer, a double or a
 * cross-slotted wafer, or perhaps a wafer (uncertain; drawn apart) (slot n at z +
 * (n-1)·pitch); empty and unmapped slots draw nothing.
 * A station the map names but `STN` did not describe is left out, as are slots beyond its
 * slot count. Station names match exactly, else ignoring case (as the controller does).
 */
export function waferDiscs(stations: readonly StationInfo[], map: WaferMap): WaferDisc[] {
  const out: WaferDisc[] = [];
  for (const [name, slots] of map.stations) {
    const info =
      stations.find((s) => s.name === name) ?? stations.find((s) => s.name.toLowerCase() === name.toLowerCase());
    if (!info) continue;
    const n = Math.min(slots.length, info.slots);
    for (let i = 0; i < n; i++) {
      const s = slots[i];
      if (s.state === 'empty' || s.state === 'unknown') continue;
      const cross = s.state === 'cross';
      const rise = cross ? info.pitch : 0; // one edge rests in the slot above
      out.push({
        station: info.name,
        slot: i + 1,
        x: info.x,
        y: info.y,
        z: info.z + i * info.pitch + rise / 2,
        yaw: info.yaw,
        state: s.state,
        wafer: s.wafer,
        tilt: cross ? Math.max(MIN_CROSS_TILT_DEG, (Math.atan2(rise, WAFER_DIAMETER) * 180) / Math.PI) : 0,
      });
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The store: asks WAFERS after each connection, follows EVT WAFER

export interface WaferState {
  /**
   * Whether the controller keeps a wafer map: null before the first `WAFERS` reply, false when
   * it refused `WAFERS` (no cell configured, or an older controller), true otherwise.
   */
  available: boolean | null;
  map: WaferMap;
  /** The refusal's text when `available` is false. */
  refusal: string;
  /** Malformed parts ignored since the last `WAFERS` reply (the newest last, at most 20). */
  ignored: string[];
}

export interface WaferStore {
  state(): WaferState;
  /** Called with the new state after every change (not at once). */
  onChange(cb: (s: WaferState) => void): Unsubscribe;
  /** Ask `WAFERS` again (resolves when its reply has been handled; never rejects). */
  refresh(): Promise<void>;
  dispose(): void;
}

const MAX_IGNORED = 20;

/**
 * Keep the wafer map of the controller behind `bus`: `WAFERS` after each connection (and
 * after each `ROBOT` reply, like `STN`), then every `EVT WAFER`. `warn` reports malformed
 * parts (default: `console.warn`).
 */
export function createWaferStore(
  bus: Bus,
  warn: (msg: string) => void = (m) => console.warn(`wrc: ${m}`),
): WaferStore {
  let st: WaferState = { available: null, map: emptyWaferMap(), refusal: '', ignored: [] };
  const listeners = new Listeners<[WaferState]>('wafer map');
  let token = 0;
  let disposed = false;

  function set(next: WaferState): void {
    st = next;
    listeners.emit(st);
  }

  /** `before` with `parts` added (each reported once through `warn`). */
  function ignore(before: string[], parts: string[]): string[] {
    for (const p of parts) warn(`ignored a malformed wafer map part: ${JSON.stringify(p)}`);
    return parts.length === 0 ? before : [...before, ...parts].slice(-MAX_IGNORED);
  }

  function snapshot(first: FirstReply, events: string[]): void {
    if (first.kind === 'NAK') {
      set({ available: false, map: emptyWaferMap(), refusal: `${first.code} ${first.text}`, ignored: [] });
      return;
    }
    const { map, bad } = wafersFromReply(first.line, events);
    set({ available: true, map, refusal: '', ignored: ignore([], bad) });
  }

  async function refresh(): Promise<void> {
    if (disposed || !bus.connected()) return;
    const mine = ++token;
    let reply: Awaited<ReturnType<Bus['request']>>;
    try {
      reply = await bus.request('WAFERS');
    } catch {
      return; // lost connection or timeout: asked again on the next connection
    }
    if (mine !== token || disposed) return; // a newer WAFERS is on its way
    snapshot(reply.first, reply.events);
  }

  function event(body: string): void {
    const part = parseWaferPart(body);
    if (!part) {
      set({ ...st, ignored: ignore(st.ignored, [body]) });
      return;
    }
    set({ ...st, available: true, refusal: '', map: applyWaferPart(st.map, part) });
  }

  const unsubs: Unsubscribe[] = [
    bus.onConnection((up) => {
      if (up) void refresh();
    }),
    bus.onRobot(() => void refresh()),
    bus.onEvent((name, body) => {
      if (!disposed && name === 'WAFER') event(body);
    }),
  ];
  void refresh();

  return {
    state: () => st,
    onChange: (cb) => listeners.add(cb),
    refresh,
    dispose() {
      disposed = true;
      listeners.clear();
      for (const u of unsubs) u();
    },
  };
}

// ---------------------------------------------------------------------------------------------
// The 3D view follows the store

/**
 * Whether the 3D view shows a wafer on the hand: what the map says once the controller has
 * one; without a cell (WAFERS refused) or before the first reply, a wafer, as the view always
 * drew before wafers were tracked.
 */
export function handShowsWafer(s: WaferState): boolean {
  return s.available === true ? s.map.hand !== null : true;
}

/**
 * Whether the 3D view shows a wafer on blade B (drawn only on a dual-blade robot): only when
 * the map says blade B holds one. Unlike the hand, blade B has no wafer drawn from before
 * wafers were tracked to keep, so without a map it is drawn empty rather than guessed full.
 */
export function bladeBShowsWafer(s: WaferState): boolean {
  return s.available === true && s.map.handB !== null;
}

/** Whether the wafer the 3D view draws on a blade is uncertain (drawn apart, with a `?`). */
export function bladeUncertain(s: WaferState, blade: Blade): boolean {
  if (s.available !== true) return false;
  return blade === 'B' ? s.map.handB !== null && s.map.handBUncertain : s.map.hand !== null && s.map.handUncertain;
}

export type WaferSink = Pick<SimulatorHandle, 'setWafer' | 'setBladeBWafer' | 'setStationWafers'> &
  Partial<Pick<SimulatorHandle, 'setWorkingStation'>>;

/**
 * Draw the map's wafers in the 3D view and follow it: the discs are placed again only when
 * the map or the stations change.
 */
export function drawWafers(
  store: WaferStore,
  stations: Pick<StationsHandle, 'stations' | 'onChange'>,
  sim: WaferSink,
): Unsubscribe {
  let drawnMap: WaferMap | null = null;
  function draw(): void {
    const s = store.state();
    drawnMap = s.map;
    sim.setStationWafers(s.available === true ? waferDiscs(stations.stations(), s.map) : []);
    onBlades(s);
  }
  function onBlades(s: WaferState): void {
    sim.setWorkingStation?.(s.available === true ? (s.map.pending?.station ?? null) : null);
    sim.setWafer(handShowsWafer(s), bladeUncertain(s, 'A'));
    sim.setBladeBWafer(bladeBShowsWafer(s), bladeUncertain(s, 'B'));
  }
  const unsubs = [
    store.onChange((s) => {
      if (s.map !== drawnMap) draw();
      else onBlades(s);
    }),
    stations.onChange(draw),
  ];
  draw();
  return () => {
    for (const u of unsubs) u();
  };
}
