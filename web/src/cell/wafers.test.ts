import { describe, expect, it } from 'vitest';
import type { Bus, FirstReply, RobotInfo } from '../protocol/bus';
import { parseStationLine, type StationInfo } from './stations';
import {
  applyWaferPart,
  createWaferStore,
  drawWafers,
  emptyWaferMap,
  formatPending,
  bladeBShowsWafer,
  bladeUncertain,
  handShowsWafer,
  hasUncertain,
  MAX_SLOTS,
  parseSlots,
  parseWaferId,
  parseWaferPart,
  parseWafersBody,
  waferDiscs,
  wafersFromReply,
  type SlotToken,
  type WaferMap,
  type WaferState,
} from './wafers';
import type { WaferDisc } from '../view3d/scene';

const W = (n: number): SlotToken => ({ state: 'wafer', wafer: `W${n}` });
const E: SlotToken = { state: 'empty', wafer: null };
const U: SlotToken = { state: 'unknown', wafer: null };
const D: SlotToken = { state: 'double', wafer: null };
const X: SlotToken = { state: 'cross', wafer: null };
const Q = (n: number): SlotToken => ({ state: 'uncertain', wafer: `W${n}` });
const times = (t: SlotToken, n: number): SlotToken[] => Array.from({ length: n }, () => t);
const range = (a: number, b: number): SlotToken[] => Array.from({ length: b - a + 1 }, (_, i) => W(a + i));

/** The documented example (docs/protocol.md, "Stations and wafers"). */
const EXAMPLE = 'hand=W3 LP1=W1,W2,-,W4..W25 LP2=-x25 AL=- PM1=? PM2=?';

describe('parseWaferId', () => {
  it('reads W<n> and w<n>, written back as W<n>', () => {
    expect(parseWaferId('W3')).toBe('W3');
    expect(parseWaferId('w17')).toBe('W17');
    expect(parseWaferId('W007')).toBe('W7');
    expect(parseWaferId('W4294967295')).toBe('W4294967295');
  });

  it('refuses anything else', () => {
    for (const t of ['', 'W', '3', 'W-1', 'W1.5', 'W 1', 'X3', 'W4294967296', 'W12345678901']) {
      expect(parseWaferId(t), t).toBeNull();
    }
  });
});

describe('parseSlots', () => {
  it('reads every single token', () => {
    expect(parseSlots('W1,-,?,D,X,w9')).toEqual([W(1), E, U, D, X, W(9)]);
  });

  it('expands rising runs W<a>..W<b>', () => {
    expect(parseSlots('W4..W25')).toEqual(range(4, 25));
    expect(parseSlots('W1,W2,-,W4..W25')).toEqual([W(1), W(2), E, ...range(4, 25)]);
    expect(parseSlots('W7..W7')).toEqual([W(7)]);
  });

  it('expands repeats <tok>x<n> of every token', () => {
    expect(parseSlots('?x25')).toEqual(times(U, 25));
    expect(parseSlots('-x25')).toEqual(times(E, 25));
    expect(parseSlots('Dx2,Xx3')).toEqual([D, D, X, X, X]);
    expect(parseSlots('W5x2')).toEqual([W(5), W(5)]);
    expect(parseSlots('-x1')).toEqual([E]);
    expect(parseSlots('W1..W3,?x2,-,Xx2,D')).toEqual([W(1), W(2), W(3), U, U, E, X, X, D]);
  });

  it('reads an uncertain slot W<n>? (perhaps that wafer, perhaps nothing), alone and repeated', () => {
    expect(parseSlots('W1?,-x24')).toEqual([Q(1), ...times(E, 24)]);
    expect(parseSlots('-,W12?,W13,w7?')).toEqual([E, Q(12), W(13), Q(7)]);
    // The controller never puts one in a run; a repeat is read like any token's.
    expect(parseSlots('W3?x2')).toEqual([Q(3), Q(3)]);
  });

  it('refuses malformed uncertain tokens', () => {
    for (const t of ['W?', '?W1', 'W1??', 'W1?..W3', 'W1..W3?', 'W1 ?', '-?', 'D?', '??']) {
      expect(parseSlots(t), JSON.stringify(t)).toBeNull();
    }
  });

  it('refuses malformed items, runs that go down and lists over MAX_SLOTS', () => {
    for (const t of [
      '',
      ',',
      'W1,,W2',
      'Z',
      'd',
      'x3',
      '?x',
      '?x0',
      '?x-1',
      'W5..W3',
      'W1..',
      '..W3',
      'W1..W3x2',
      'W1...W3',
      '?x25 ',
      ' ?x25',
      '?X25',
    ]) {
      expect(parseSlots(t), JSON.stringify(t)).toBeNull();
    }
    expect(parseSlots(`?x${MAX_SLOTS}`)).toHaveLength(MAX_SLOTS);
    expect(parseSlots(`?x${MAX_SLOTS + 1}`)).toBeNull();
    expect(parseSlots(`-,?x${MAX_SLOTS}`)).toBeNull();
    expect(parseSlots('W1..W4000000000')).toBeNull(); // would allocate billions of slots
    expect(parseSlots(`${times(U, MAX_SLOTS).map(() => '?').join(',')},-`)).toBeNull();
  });
});

describe('parseWaferPart', () => {
  it('reads the hand, a station, a pending transfer and its end', () => {
    expect(parseWaferPart('hand=W3')).toEqual({ place: 'hand', wafer: 'W3', uncertain: false });
    expect(parseWaferPart('hand=-')).toEqual({ place: 'hand', wafer: null, uncertain: false });
    // A wafer the map keeps on the hand while the board does not answer.
    expect(parseWaferPart('hand=W3?')).toEqual({ place: 'hand', wafer: 'W3', uncertain: true });
    expect(parseWaferPart('hand.B=W7?')).toEqual({ place: 'handB', wafer: 'W7', uncertain: true });
    expect(parseWaferPart('hand=-?')).toBeNull();
    expect(parseWaferPart('hand=W3??')).toBeNull();
    expect(parseWaferPart('LP1=W1,W2,-,W4..W25')).toEqual({
      place: 'station',
      name: 'LP1',
      slots: [W(1), W(2), E, ...range(4, 25)],
    });
    expect(parseWaferPart('pending=get:LP1.3:W3')).toEqual({
      place: 'pending',
      pending: { kind: 'get', blade: 'A', station: 'LP1', slot: 3, wafer: 'W3' },
    });
    expect(parseWaferPart('pending=put:PM_2-a.1:W26')).toEqual({
      place: 'pending',
      pending: { kind: 'put', blade: 'A', station: 'PM_2-a', slot: 1, wafer: 'W26' },
    });
    expect(parseWaferPart('pending=-')).toEqual({ place: 'pending', pending: null });
  });

  it("reads blade B of a dual-blade robot and a transfer it makes (':B')", () => {
    expect(parseWaferPart('hand.B=W7')).toEqual({ place: 'handB', wafer: 'W7', uncertain: false });
    expect(parseWaferPart('hand.B=-')).toEqual({ place: 'handB', wafer: null, uncertain: false });
    expect(parseWaferPart('WAFER hand.B=w07')).toEqual({ place: 'handB', wafer: 'W7', uncertain: false });
    expect(parseWaferPart('pending=get:LP1.3:W3:B')).toEqual({
      place: 'pending',
      pending: { kind: 'get', blade: 'B', station: 'LP1', slot: 3, wafer: 'W3' },
    });
    expect(parseWaferPart('pending=put:PM1.1:W7:b')).toMatchObject({ pending: { kind: 'put', blade: 'B' } });
    // An explicit :A is blade A, as no suffix is.
    expect(parseWaferPart('pending=put:PM1.1:W7:A')).toMatchObject({ pending: { blade: 'A' } });
    for (const t of ['hand.B=', 'hand.B=?', 'hand.B=W1,W2', 'hand.C=W1', 'hand.=W1', 'pending=get:LP1.3:W3:C', 'pending=get:LP1.3:W3:']) {
      expect(parseWaferPart(t), t).toBeNull();
    }
  });

  it('skips a leading WAFER (an event line without EVT) and blanks around it', () => {
    expect(parseWaferPart('WAFER hand=W3')).toEqual({ place: 'hand', wafer: 'W3', uncertain: false });
    expect(parseWaferPart('  AL=-  ')).toEqual({ place: 'station', name: 'AL', slots: [E] });
  });

  it('returns null for malformed parts', () => {
    for (const t of [
      '',
      'hand',
      '=W3',
      'hand=',
      'hand=?',
      'hand=W3,W4',
      'LP1=',
      'LP1=W1 W2',
      'LP1=Q',
      'L.P1=-',
      'pending=',
      'pending=get',
      'pending=move:LP1.3:W3',
      'pending=get:LP1:W3',
      'pending=get:LP1.0:W3',
      'pending=get:LP1.x:W3',
      'pending=get:LP1.3:3',
      'pending=get:LP1.3:W3:more',
      'parts=3',
    ]) {
      // `parts=3` parses as a station named "parts" with a bad slot list: still null.
      expect(parseWaferPart(t), JSON.stringify(t)).toBeNull();
    }
    expect(parseWaferPart(undefined as unknown as string)).toBeNull();
  });
});

describe('applyWaferPart', () => {
  it('replaces one place and leaves the old map as it was', () => {
    const a = parseWafersBody(EXAMPLE).map;
    const b = applyWaferPart(a, { place: 'station', name: 'LP2', slots: [W(26), ...times(E, 24)] });
    expect(b.stations.get('LP2')?.[0]).toEqual(W(26));
    expect(a.stations.get('LP2')?.[0]).toEqual(E);
    expect([...b.stations.keys()]).toEqual(['LP1', 'LP2', 'AL', 'PM1', 'PM2']);
    const c = applyWaferPart(b, { place: 'station', name: 'BUF', slots: [E] });
    expect([...c.stations.keys()]).toEqual(['LP1', 'LP2', 'AL', 'PM1', 'PM2', 'BUF']);
    expect(applyWaferPart(c, { place: 'hand', wafer: null, uncertain: false }).hand).toBeNull();
    expect(c.hand).toBe('W3');
    const d = applyWaferPart(c, { place: 'handB', wafer: 'W8', uncertain: false });
    expect(d.handB).toBe('W8');
    expect(d.hand).toBe('W3'); // blade B is its own place
    expect(c.handB).toBeNull();
    const e = applyWaferPart(c, { place: 'hand', wafer: 'W3', uncertain: true });
    expect(e.handUncertain).toBe(true);
    expect(applyWaferPart(e, { place: 'hand', wafer: 'W3', uncertain: false }).handUncertain).toBe(false);
  });
});

describe('parseWafersBody', () => {
  it('parses the documented example in station order', () => {
    const { map, bad } = parseWafersBody(EXAMPLE);
    expect(bad).toEqual([]);
    expect(map.hand).toBe('W3');
    expect(map.pending).toBeNull();
    expect([...map.stations.keys()]).toEqual(['LP1', 'LP2', 'AL', 'PM1', 'PM2']);
    expect(map.stations.get('LP1')).toEqual([W(1), W(2), E, ...range(4, 25)]);
    expect(map.stations.get('LP2')).toEqual(times(E, 25));
    expect(map.stations.get('AL')).toEqual([E]);
    expect(map.stations.get('PM1')).toEqual([U]);
  });

  it('reads a pending transfer and a fresh map', () => {
    const { map } = parseWafersBody('hand=- LP1=W1,W2,W3 pending=get:LP1.3:W3');
    expect(map.hand).toBeNull();
    expect(map.pending).toEqual({ kind: 'get', blade: 'A', station: 'LP1', slot: 3, wafer: 'W3' });
    const fresh = parseWafersBody('hand=- LP1=?x25 LP2=?x25 AL=? PM1=? PM2=?').map;
    expect(fresh.stations.get('LP1')).toEqual(times(U, 25));
  });

  it('keeps the good parts and lists the malformed ones', () => {
    const { map, bad } = parseWafersBody('hand=W3 LP1=W1,Q LP2=-x25 junk pending=get:LP1 AL=-');
    expect(bad).toEqual(['LP1=W1,Q', 'junk', 'pending=get:LP1']);
    expect([...map.stations.keys()]).toEqual(['LP2', 'AL']);
    expect(map.hand).toBe('W3');
    expect(map.pending).toBeNull();
    expect(parseWafersBody('').map).toEqual(emptyWaferMap());
  });
});

describe('wafersFromReply', () => {
  it('reads a one-line ACK with its id (and without one)', () => {
    const { map, bad } = wafersFromReply(`ACK 3 ${EXAMPLE}`, []);
    expect(bad).toEqual([]);
    expect(map).toEqual(parseWafersBody(EXAMPLE).map);
    expect(wafersFromReply(`ACK ${EXAMPLE}`, []).map).toEqual(map);
    expect(wafersFromReply(`ACK 3 ${EXAMPLE}*5A`, []).map).toEqual(map);
  });

  it('builds a split map from the EVT WAFER lines before ACK parts=<n>', () => {
    const events = [
      'INPUT 3 1',
      'WAFER hand=W3',
      'WAFER LP1=W1,W2,-,W4..W25',
      'WAFER LP2=-x25',
      'WAFER AL=-',
      'WAFER PM1=?',
      'WAFER PM2=?',
      'WAFER pending=put:LP2.1:W3',
    ];
    const { map, bad } = wafersFromReply('ACK 9 parts=7', events);
    expect(bad).toEqual([]);
    expect(map.hand).toBe('W3');
    expect([...map.stations.keys()]).toEqual(['LP1', 'LP2', 'AL', 'PM1', 'PM2']);
    expect(map.pending).toEqual({ kind: 'put', blade: 'A', station: 'LP2', slot: 1, wafer: 'W3' });
  });

  it('uses only the last n parts: an older broadcast before them does not leak in', () => {
    const events = ['WAFER pending=get:LP1.3:W3', 'WAFER hand=-', 'WAFER LP1=W1,W2,-'];
    const { map } = wafersFromReply('ACK 9 parts=2', events);
    expect(map.pending).toBeNull();
    expect(map.stations.get('LP1')).toEqual([W(1), W(2), E]);
  });

  it('says so when parts are missing or malformed, and keeps the rest', () => {
    const r = wafersFromReply('ACK 9 parts=4', ['WAFER hand=W1', 'WAFER LP1=bad', 'WAFER AL=-']);
    expect(r.map.hand).toBe('W1');
    expect([...r.map.stations.keys()]).toEqual(['AL']);
    expect(r.bad).toEqual(['WAFER LP1=bad', 'parts=4 but 3 EVT WAFER lines came']);
    expect(wafersFromReply('ACK 9 parts=0', []).map).toEqual(emptyWaferMap());
  });

  it("reads a dual-blade robot's reply: hand.B and a blade B transfer", () => {
    const { map, bad } = wafersFromReply('ACK 3 hand=W2 hand.B=- LP1=W1,-,W3..W25 pending=get:LP1.3:W3:B', []);
    expect(bad).toEqual([]);
    expect(map.hand).toBe('W2');
    expect(map.handB).toBeNull();
    expect(map.stations.get('LP1')).toEqual([W(1), E, ...range(3, 25)]);
    expect(map.pending).toEqual({ kind: 'get', blade: 'B', station: 'LP1', slot: 3, wafer: 'W3' });
    const parts = wafersFromReply('ACK 4 parts=3', ['WAFER hand=-', 'WAFER hand.B=W7', 'WAFER AL=-']);
    expect(parts.bad).toEqual([]);
    expect(parts.map).toMatchObject({ hand: null, handB: 'W7', pending: null });
    // A single-hand robot lists no hand.B: blade B stays empty.
    expect(parseWafersBody(EXAMPLE).map.handB).toBeNull();
  });

  it('never throws on garbage', () => {
    expect(() => wafersFromReply('', [])).not.toThrow();
    expect(() => wafersFromReply(undefined as unknown as string, [])).not.toThrow();
    expect(wafersFromReply('ACK', []).map).toEqual(emptyWaferMap());
  });
});

describe('formatPending', () => {
  it('names the transfer', () => {
    expect(formatPending({ kind: 'get', blade: 'A', station: 'LP1', slot: 3, wafer: 'W3' })).toBe('GET LP1.3 W3');
    expect(formatPending({ kind: 'put', blade: 'B', station: 'PM1', slot: 1, wafer: 'W7' })).toBe('PUT PM1.1 W7 with blade B');
  });
});

// ---- the 3D view's wafers ----

const LP1 = parseStationLine(
  'LP1 kind=load_port x=294.449 y=-170 z=20 yaw=-30 slots=25 pitch=10 approach=220 stroke=6',
)!;
const AL = parseStationLine('AL kind=aligner x=0 y=300 z=80 yaw=90 slots=1 pitch=0 approach=200')!;

function mapOf(body: string): WaferMap {
  return parseWafersBody(body).map;
}

describe('waferDiscs', () => {
  it('puts a disc at each occupied slot: slot n at z + (n-1)·pitch', () => {
    const discs = waferDiscs([LP1, AL], mapOf('hand=- LP1=W1,-,?,W4,-x21 AL=W9'));
    expect(discs.map((d) => `${d.station}.${d.slot}`)).toEqual(['LP1.1', 'LP1.4', 'AL.1']);
    const [a, b, c] = discs;
    expect(a).toEqual({ station: 'LP1', slot: 1, x: 294.449, y: -170, z: 20, yaw: -30, state: 'wafer', wafer: 'W1', tilt: 0 });
    expect(b.z).toBeCloseTo(50);
    expect(c).toMatchObject({ x: 0, y: 300, z: 80, yaw: 90, wafer: 'W9' });
  });

  it('draws double and cross-slotted wafers, a cross one tilted and half a pitch up', () => {
    const discs = waferDiscs([LP1], mapOf('LP1=D,-,X'));
    expect(discs.map((d) => d.state)).toEqual(['double', 'cross']);
    expect(discs[0].tilt).toBe(0);
    expect(discs[1].z).toBeCloseTo(20 + 2 * 10 + 5);
    expect(discs[1].tilt).toBeGreaterThanOrEqual(3);
  });

  it('draws an uncertain slot apart, where its wafer would be', () => {
    const discs = waferDiscs([LP1], mapOf('hand=W1? LP1=W1?,-,W3'));
    expect(discs.map((d) => [d.slot, d.state, d.wafer])).toEqual([
      [1, 'uncertain', 'W1'],
      [3, 'wafer', 'W3'],
    ]);
    expect(discs[0]).toMatchObject({ z: 20, tilt: 0 });
  });

  it('leaves out stations STN did not describe and slots beyond the slot count; matches names ignoring case', () => {
    expect(waferDiscs([AL], mapOf('LP1=W1 AL=W1,W2'))).toHaveLength(1);
    expect(waferDiscs([{ ...AL, name: 'al' } as StationInfo], mapOf('AL=W1'))).toHaveLength(1);
    expect(waferDiscs([], mapOf(EXAMPLE))).toEqual([]);
  });
});

describe('hasUncertain and bladeUncertain', () => {
  it('find an uncertain slot or blade; the same wafer may be uncertain in two places', () => {
    const m = mapOf('hand=W1? LP1=-,W2..W25 LP2=W1?,-x24');
    expect(m.hand).toBe('W1');
    expect(m.handUncertain).toBe(true);
    expect(m.stations.get('LP2')![0]).toEqual(Q(1));
    expect(hasUncertain(m)).toBe(true);
    expect(hasUncertain(mapOf('hand=W1 LP2=W1?,-x24'))).toBe(true);
    expect(hasUncertain(mapOf('hand=W1 hand.B=W7? LP2=-x25'))).toBe(true);
    expect(hasUncertain(mapOf('hand=W1 LP1=W2..W25,? LP2=-x25'))).toBe(false);
    const st = (body: string, available: boolean | null = true): WaferState => ({ available, map: mapOf(body), refusal: '', ignored: [] });
    expect(bladeUncertain(st('hand=W1?'), 'A')).toBe(true);
    expect(bladeUncertain(st('hand=W1? hand.B=W2'), 'B')).toBe(false);
    expect(bladeUncertain(st('hand=- hand.B=W2?'), 'B')).toBe(true);
    expect(bladeUncertain(st('hand=W1?', false), 'A')).toBe(false);
  });
});

describe('handShowsWafer', () => {
  const st = (available: boolean | null, hand: string | null): WaferState => ({
    available,
    map: { ...emptyWaferMap(), hand },
    refusal: '',
    ignored: [],
  });
  it('follows the map when there is one, else shows a wafer as before', () => {
    expect(handShowsWafer(st(true, 'W3'))).toBe(true);
    expect(handShowsWafer(st(true, null))).toBe(false);
    expect(handShowsWafer(st(false, null))).toBe(true);
    expect(handShowsWafer(st(null, null))).toBe(true);
  });
});

describe('bladeBShowsWafer', () => {
  const st = (available: boolean | null, handB: string | null): WaferState => ({
    available,
    map: { ...emptyWaferMap(), hand: 'W1', handB },
    refusal: '',
    ignored: [],
  });
  it('shows a wafer on blade B only when the map says it holds one', () => {
    expect(bladeBShowsWafer(st(true, 'W7'))).toBe(true);
    expect(bladeBShowsWafer(st(true, null))).toBe(false);
    // Without a map nothing is known about blade B: drawn empty, not guessed full.
    expect(bladeBShowsWafer(st(false, null))).toBe(false);
    expect(bladeBShowsWafer(st(null, null))).toBe(false);
  });
});

// ---- the store, with a fake bus ----

type Reply = { first: FirstReply; events: string[] };

class FakeBus implements Bus {
  up = true;
  sent: string[] = [];
  reply: (line: string) => Reply | Error | Promise<Reply> = () => new Error('no reply');
  private conn: ((c: boolean, d: string) => void)[] = [];
  private robots: ((r: RobotInfo) => void)[] = [];
  private evts: ((n: string, b: string, l: string) => void)[] = [];

  connected(): boolean {
    return this.up;
  }
  onConnection(cb: (c: boolean, d: string) => void) {
    this.conn.push(cb);
    return () => void (this.conn = this.conn.filter((x) => x !== cb));
  }
  robot(): RobotInfo | null {
    return null;
  }
  onRobot(cb: (r: RobotInfo) => void) {
    this.robots.push(cb);
    return () => void (this.robots = this.robots.filter((x) => x !== cb));
  }
  onSample() {
    return () => undefined;
  }
  onEvent(cb: (n: string, b: string, l: string) => void) {
    this.evts.push(cb);
    return () => void (this.evts = this.evts.filter((x) => x !== cb));
  }
  async request(line: string) {
    this.sent.push(line);
    const r = await this.reply(line);
    if (r instanceof Error) throw r;
    return { ...r, final: null };
  }
  upload(): Promise<Reply> {
    return Promise.reject(new Error('unused'));
  }
  connect(): void {
    this.up = true;
    for (const cb of this.conn) cb(true, 'test');
  }
  event(line: string): void {
    const m = /^EVT\s+(\S+)\s*(.*)$/.exec(line)!;
    for (const cb of this.evts) cb(m[1].toUpperCase(), m[2], line);
  }
}

const ack = (body: string): FirstReply => ({ kind: 'ACK', id: 1, fields: {}, line: `ACK 1 ${body}` });
const nak: FirstReply = {
  kind: 'NAK',
  id: 1,
  code: 124,
  text: 'this controller has no wafer cell (no stations file)',
  line: 'NAK 1 124 this controller has no wafer cell (no stations file)',
};
const flush = () => new Promise((r) => setTimeout(r, 0));

function setup(reply: Reply | Error, connected = true) {
  const bus = new FakeBus();
  bus.up = connected;
  bus.reply = () => reply;
  const warnings: string[] = [];
  const store = createWaferStore(bus, (m) => warnings.push(m));
  const seen: WaferState[] = [];
  store.onChange((s) => seen.push(s));
  return { bus, store, warnings, seen };
}

describe('createWaferStore', () => {
  it('asks WAFERS when connected and holds the map', async () => {
    const { bus, store, seen } = setup({ first: ack(EXAMPLE), events: [] });
    expect(store.state().available).toBeNull();
    await flush();
    expect(bus.sent).toEqual(['WAFERS']);
    expect(store.state().available).toBe(true);
    expect(store.state().map).toEqual(parseWafersBody(EXAMPLE).map);
    expect(seen).toHaveLength(1);
  });

  it('does not ask while disconnected; asks on connection and again after ROBOT', async () => {
    const { bus } = setup({ first: ack(EXAMPLE), events: [] }, false);
    await flush();
    expect(bus.sent).toEqual([]);
    bus.connect();
    await flush();
    expect(bus.sent).toEqual(['WAFERS']);
  });

  it('follows EVT WAFER: a transfer begins, commits and ends', async () => {
    const { bus, store } = setup({ first: ack('hand=- LP1=W1,W2,W3 AL=-'), events: [] });
    await flush();
    bus.event('EVT WAFER pending=get:LP1.3:W3');
    expect(store.state().map.pending).toEqual({ kind: 'get', blade: 'A', station: 'LP1', slot: 3, wafer: 'W3' });
    bus.event('EVT WAFER hand=W3');
    bus.event('EVT WAFER LP1=W1,W2,-');
    bus.event('EVT WAFER pending=-');
    const m = store.state().map;
    expect(m.hand).toBe('W3');
    expect(m.stations.get('LP1')).toEqual([W(1), W(2), E]);
    expect(m.pending).toBeNull();
    bus.event('EVT STATION LP1 kind=load_port'); // other events change nothing
    expect(store.state().map).toBe(m);
  });

  it('takes a split reply (EVT WAFER parts, then ACK parts=n) as the whole map', async () => {
    const bus = new FakeBus();
    const parts = ['hand=W3', 'LP1=W1,W2,-,W4..W25', 'LP2=-x25'];
    // The parts arrive as events (the live handler sees them too) before the ACK.
    bus.reply = () => {
      for (const p of parts) bus.event(`EVT WAFER ${p}`);
      return { first: ack('parts=3'), events: parts.map((p) => `WAFER ${p}`) };
    };
    const store = createWaferStore(bus, () => undefined);
    bus.event('EVT WAFER OLD=-'); // a station of an earlier map: gone after the reply
    await flush();
    const m = store.state().map;
    expect([...m.stations.keys()]).toEqual(['LP1', 'LP2']);
    expect(m.hand).toBe('W3');
    expect(store.state().available).toBe(true);
  });

  it('marks the map unavailable when WAFERS is refused (no cell)', async () => {
    const { store } = setup({ first: nak, events: [] });
    await flush();
    expect(store.state().available).toBe(false);
    expect(store.state().refusal).toMatch(/^124 this controller has no wafer cell/);
    expect(store.state().map.stations.size).toBe(0);
  });

  it('ignores malformed parts, warns and never throws', async () => {
    const { bus, store, warnings } = setup({ first: ack('hand=- LP1=W1,Q AL=-'), events: [] });
    await flush();
    expect([...store.state().map.stations.keys()]).toEqual(['AL']);
    expect(store.state().ignored).toEqual(['LP1=W1,Q']);
    const before = store.state().map;
    expect(() => bus.event('EVT WAFER LP1=W9..W1')).not.toThrow();
    expect(() => bus.event('EVT WAFER')).not.toThrow();
    expect(store.state().map).toBe(before);
    expect(store.state().ignored).toEqual(['LP1=W1,Q', 'LP1=W9..W1', '']);
    expect(warnings).toHaveLength(3);
    expect(warnings[0]).toMatch(/malformed wafer map part: "LP1=W1,Q"/);
    // The next WAFERS reply starts a clean list.
    bus.reply = () => ({ first: ack('hand=- AL=-'), events: [] });
    await store.refresh();
    expect(store.state().ignored).toEqual([]);
  });

  it('keeps the map when a request fails, and uses only the newest of two replies', async () => {
    const { bus, store } = setup({ first: ack('hand=- AL=W1'), events: [] });
    await flush();
    bus.reply = () => new Error('connection lost');
    await expect(store.refresh()).resolves.toBeUndefined();
    expect(store.state().map.stations.get('AL')).toEqual([W(1)]);

    let release: (r: Reply) => void = () => undefined;
    bus.reply = () => new Promise<Reply>((r) => (release = r));
    const older = store.refresh();
    const releaseOlder = release;
    bus.reply = () => ({ first: ack('hand=- AL=W2'), events: [] });
    await store.refresh();
    releaseOlder({ first: ack('hand=- AL=W3'), events: [] });
    await older;
    expect(store.state().map.stations.get('AL')).toEqual([W(2)]);
  });

  it('stops listening after dispose', async () => {
    const { bus, store, seen } = setup({ first: ack('hand=- AL=-'), events: [] });
    await flush();
    store.dispose();
    bus.event('EVT WAFER hand=W1');
    bus.connect();
    await flush();
    expect(store.state().map.hand).toBeNull();
    expect(bus.sent).toEqual(['WAFERS']);
    expect(seen).toHaveLength(1);
  });
});

describe('drawWafers', () => {
  class FakeSim {
    discs: WaferDisc[][] = [];
    hand: boolean[] = [];
    handUncertain: boolean[] = [];
    setStationWafers(d: readonly WaferDisc[]) {
      this.discs.push([...d]);
    }
    setWafer(on: boolean, uncertain = false) {
      this.hand.push(on);
      this.handUncertain.push(uncertain);
    }
    bladeB: boolean[] = [];
    bladeBUncertain: boolean[] = [];
    setBladeBWafer(on: boolean, uncertain = false) {
      this.bladeB.push(on);
      this.bladeBUncertain.push(uncertain);
    }
  }
  function stationsOf(list: StationInfo[]) {
    const cbs: (() => void)[] = [];
    return {
      list,
      stations: () => list,
      onChange: (cb: () => void) => {
        cbs.push(cb);
        return () => undefined;
      },
      changed: () => cbs.forEach((cb) => cb()),
    };
  }

  it('draws the map once per change and shows the hand as the map says', async () => {
    const { bus, store } = setup({ first: ack('hand=- LP1=W1,W2,-x23 AL=-'), events: [] });
    const sim = new FakeSim();
    const st = stationsOf([LP1, AL]);
    drawWafers(store, st, sim);
    expect(sim.discs).toEqual([[]]); // before the reply: nothing in the stations…
    expect(sim.hand).toEqual([true]); // …and the wafer on the hand, as always
    await flush();
    expect(sim.discs[1].map((d) => d.wafer)).toEqual(['W1', 'W2']);
    expect(sim.hand[1]).toBe(false);
    bus.event('EVT WAFER hand=W2');
    bus.event('EVT WAFER LP1=W1,-x24');
    expect(sim.discs).toHaveLength(4);
    expect(sim.discs[3].map((d) => d.wafer)).toEqual(['W1']);
    expect(sim.hand.at(-1)).toBe(true);
    bus.event('EVT WAFER LP1=junk'); // ignored: the map is the same, nothing is redrawn
    expect(sim.discs).toHaveLength(4);
    st.changed(); // a station taught again: redraw
    expect(sim.discs).toHaveLength(5);
  });

  it("shows blade B's wafer as the map says, apart from the hand's", async () => {
    const { bus, store } = setup({ first: ack('hand=W1 hand.B=- AL=-'), events: [] });
    const sim = new FakeSim();
    drawWafers(store, stationsOf([AL]), sim);
    expect(sim.bladeB).toEqual([false]); // before the reply: blade B empty
    await flush();
    expect(sim.hand.at(-1)).toBe(true);
    expect(sim.bladeB.at(-1)).toBe(false);
    bus.event('EVT WAFER hand.B=W7');
    expect(sim.bladeB.at(-1)).toBe(true);
    expect(sim.hand.at(-1)).toBe(true);
    bus.event('EVT WAFER hand=-');
    expect(sim.hand.at(-1)).toBe(false);
    expect(sim.bladeB.at(-1)).toBe(true);
  });

  it('draws an uncertain wafer on a blade and in a slot apart, until the map settles it', async () => {
    const { bus, store } = setup({ first: ack('hand=W1? hand.B=- LP1=W1?,-x24'), events: [] });
    const sim = new FakeSim();
    drawWafers(store, stationsOf([LP1]), sim);
    await flush();
    expect(sim.hand.at(-1)).toBe(true);
    expect(sim.handUncertain.at(-1)).toBe(true);
    expect(sim.bladeBUncertain.at(-1)).toBe(false);
    expect(sim.discs.at(-1)!.map((d) => d.state)).toEqual(['uncertain']);
    bus.event('EVT WAFER hand=-'); // SENSE found the blade empty
    expect(sim.hand.at(-1)).toBe(false);
    expect(sim.handUncertain.at(-1)).toBe(false);
    bus.event('EVT WAFER LP1=W1,-x24'); // MAP found it in the slot
    expect(sim.discs.at(-1)!.map((d) => d.state)).toEqual(['wafer']);
  });

  it('keeps the wafer on the hand when the controller has no cell', async () => {
    const { store } = setup({ first: nak, events: [] });
    const sim = new FakeSim();
    drawWafers(store, stationsOf([LP1]), sim);
    await flush();
    expect(sim.hand.every((h) => h)).toBe(true);
    expect(sim.discs.at(-1)).toEqual([]);
  });
});
