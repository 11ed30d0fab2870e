import { describe, expect, it } from 'vitest';
import type { Bus, FirstReply, RobotInfo } from '../protocol/bus';
import type { StationSpec } from '../view3d/scene';
import { mountStations, parseObstacleLine, parseStationLine, stationSpec, type StationSink } from './stations';

const LP1 =
  'LP1 kind=load_port x=294.449 y=-170 z=20 yaw=-30 slots=25 pitch=10 approach=220 stroke=6 ' +
  'speed=30 interlock=14 posture=any';
const AL = 'AL kind=aligner x=0 y=350 z=80 yaw=90 slots=1 pitch=0 approach=150 interlock=none posture=right';
const PM1 = 'PM1 kind=process_module x=-300 y=0 z=100 yaw=180 slots=1 pitch=0 approach=200';

describe('parseStationLine', () => {
  it('parses the example line', () => {
    expect(parseStationLine(LP1)).toEqual({
      name: 'LP1',
      kind: 'load_port',
      x: 294.449,
      y: -170,
      z: 20,
      yaw: -30,
      slots: 25,
      pitch: 10,
      approach: 220,
      stroke: 6,
      speed: 30,
      interlock: 14,
      posture: 'any',
      volume: null,
    });
  });

  it('reads interlock=none, posture and absent optional fields', () => {
    const s = parseStationLine(AL);
    expect(s?.interlock).toBeNull();
    expect(s?.posture).toBe('right');
    expect(s?.stroke).toBeNull();
    expect(s?.speed).toBeNull();
    expect(parseStationLine(PM1)?.interlock).toBeNull();
    expect(parseStationLine(PM1)?.posture).toBe('any');
  });

  it('ignores unknown keys and extra blanks', () => {
    const s = parseStationLine(`  ${LP1}   future=1 mapper=yes  `);
    expect(s).toEqual(parseStationLine(LP1));
  });

  it('returns null for a missing name or a missing or malformed required number', () => {
    expect(parseStationLine('')).toBeNull();
    expect(parseStationLine('   ')).toBeNull();
    expect(parseStationLine('kind=load_port x=1 y=2 z=3 yaw=0 slots=1 pitch=0 approach=100')).toBeNull();
    for (const key of ['x', 'y', 'z', 'yaw', 'slots', 'pitch', 'approach']) {
      const without = LP1.replace(new RegExp(` ${key}=\\S+`), '');
      expect(parseStationLine(without), `without ${key}`).toBeNull();
      const bad = LP1.replace(new RegExp(` ${key}=\\S+`), ` ${key}=abc`);
      expect(parseStationLine(bad), `${key}=abc`).toBeNull();
      const empty = LP1.replace(new RegExp(` ${key}=\\S+`), ` ${key}=`);
      expect(parseStationLine(empty), `${key}=`).toBeNull();
    }
    expect(parseStationLine(LP1.replace('slots=25', 'slots=0'))).toBeNull();
    expect(parseStationLine(undefined as unknown as string)).toBeNull();
  });
});

describe('stationSpec', () => {
  it('holds a 300 mm wafer, opens towards the robot and covers every slot', () => {
    const s = parseStationLine(LP1)!;
    const b = stationSpec(s);
    const a = (s.yaw * Math.PI) / 180;
    // Box centre relative to the wafer centre, along +yaw (u) and across (v).
    const u = (b.x - s.x) * Math.cos(a) + (b.y - s.y) * Math.sin(a);
    const v = -(b.x - s.x) * Math.sin(a) + (b.y - s.y) * Math.cos(a);
    expect(Math.abs(v)).toBeLessThan(1e-9);
    expect(u).toBeGreaterThan(0); // reaches further along +yaw than towards the robot
    expect(u - b.depth / 2).toBeLessThanOrEqual(-150); // open side before the wafer's near edge
    expect(u + b.depth / 2).toBeGreaterThanOrEqual(150);
    expect(b.width).toBeGreaterThanOrEqual(300);
    expect(b.yaw).toBe(-30);
    expect(b.z!).toBeLessThanOrEqual(s.z);
    expect(b.z! + b.height).toBeGreaterThan(s.z + (s.slots - 1) * s.pitch);
    expect(b.height).toBeGreaterThanOrEqual(250);
    expect(stationSpec(parseStationLine(AL)!).height).toBeGreaterThanOrEqual(40);
    expect(b.color).not.toBe(stationSpec(parseStationLine(AL)!).color);
    expect(b.name).toBe('LP1');
  });
});

// ---- mountStations with a fake bus and a fake simulator ----

type Reply = { first: FirstReply; events: string[] };

class FakeBus implements Bus {
  up = true;
  sent: string[] = [];
  reply: (line: string) => Reply | Error = () => new Error('no reply');
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
  request(line: string) {
    this.sent.push(line);
    const r = this.reply(line);
    if (r instanceof Error) return Promise.reject(r);
    return Promise.resolve({ ...r, final: null });
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

class FakeSim implements StationSink {
  boxes = new Map<string, StationSpec>();
  calls: string[] = [];
  addStation(spec: StationSpec): string {
    let id = spec.name;
    for (let k = 2; this.boxes.has(id); k++) id = `${spec.name}#${k}`;
    this.boxes.set(id, spec);
    this.calls.push(`add ${id}`);
    return id;
  }
  removeStation(id: string): void {
    this.boxes.delete(id);
    this.calls.push(`remove ${id}`);
  }
  clearStations(): void {
    this.boxes.clear();
    this.calls.push('clear');
  }
}

const ack = (n: number): FirstReply => ({ kind: 'ACK', id: 1, fields: { stations: String(n) }, line: `ACK 1 stations=${n}` });
const flush = () => new Promise((r) => setTimeout(r, 0));

function setup(reply: Reply | Error, connected = true) {
  const bus = new FakeBus();
  bus.up = connected;
  bus.reply = () => reply;
  const sim = new FakeSim();
  const h = mountStations(bus, sim);
  return { bus, sim, h };
}

describe('mountStations', () => {
  it('draws every station of the STN reply, ignoring unrelated events', async () => {
    const { bus, sim, h } = setup({
      first: ack(3),
      events: [`STATION ${LP1}`, 'INPUT 3 1', `STATION ${AL}`, 'STATION garbage', `STATION ${PM1}`],
    });
    await flush();
    expect(bus.sent).toEqual(['STN']);
    expect([...sim.boxes.keys()].sort()).toEqual(['AL', 'LP1', 'PM1']);
    expect(sim.boxes.get('LP1')).toEqual(stationSpec(parseStationLine(LP1)!));
    expect(h.stations().map((s) => s.name)).toEqual(['LP1', 'AL', 'PM1']);
  });

  it('asks again after a reconnection and redraws from scratch', async () => {
    const { bus, sim } = setup({ first: ack(2), events: [`STATION ${LP1}`, `STATION ${AL}`] });
    await flush();
    bus.reply = () => ({ first: ack(1), events: [`STATION ${PM1}`] });
    bus.connect();
    await flush();
    expect(bus.sent).toEqual(['STN', 'STN']);
    expect([...sim.boxes.keys()]).toEqual(['PM1']);
  });

  it('does not ask while disconnected; asks on connection', async () => {
    const { bus, sim } = setup({ first: ack(1), events: [`STATION ${LP1}`] }, false);
    await flush();
    expect(bus.sent).toEqual([]);
    bus.connect();
    await flush();
    expect(bus.sent).toEqual(['STN']);
    expect([...sim.boxes.keys()]).toEqual(['LP1']);
  });

  it('replaces one station on EVT STATION (after TEACH) and adds a new one', async () => {
    const { bus, sim, h } = setup({ first: ack(2), events: [`STATION ${LP1}`, `STATION ${AL}`] });
    await flush();
    sim.calls = [];
    bus.event(`EVT STATION ${LP1.replace('x=294.449', 'x=300')}`);
    expect(sim.calls).toEqual(['remove LP1', 'add LP1']);
    expect(sim.boxes.size).toBe(2);
    expect(h.stations().find((s) => s.name === 'LP1')?.x).toBe(300);
    expect(sim.boxes.get('LP1')).toEqual(stationSpec({ ...parseStationLine(LP1)!, x: 300 }));
    bus.event(`EVT STATION ${PM1}`);
    expect([...sim.boxes.keys()].sort()).toEqual(['AL', 'LP1', 'PM1']);
    bus.event('EVT STATION broken');
    bus.event('EVT INPUT 3 1');
    expect(sim.boxes.size).toBe(3);
  });

  it('draws nothing and does not throw when an older controller answers NAK 100', async () => {
    const { bus, sim } = setup({
      first: { kind: 'NAK', id: 1, code: 100, text: 'unknown verb STN', line: 'NAK 1 100 unknown verb STN' },
      events: [],
    });
    await flush();
    expect(bus.sent).toEqual(['STN']);
    expect(sim.boxes.size).toBe(0);
    expect(sim.calls).toEqual([]);
  });

  it('ignores a failed request', async () => {
    const { sim, h } = setup(new Error('connection lost'));
    await flush();
    await expect(h.refresh()).resolves.toBeUndefined();
    expect(sim.calls).toEqual([]);
  });

  it('tells its listeners when the stations drawn change', async () => {
    const { bus, h } = setup({ first: ack(1), events: [`STATION ${LP1}`] });
    let n = 0;
    h.onChange(() => n++);
    await flush();
    expect(n).toBe(1); // the STN reply
    bus.event(`EVT STATION ${AL}`);
    expect(n).toBe(2);
    bus.event('EVT STATION broken');
    bus.event('EVT INPUT 3 1');
    expect(n).toBe(2);
    bus.reply = () => ({
      first: { kind: 'NAK', id: 2, code: 100, text: 'unknown verb STN', line: 'NAK 2 100 unknown verb STN' },
      events: [],
    });
    await h.refresh();
    expect(n).toBe(3); // an older controller: the stations were removed
    await h.refresh();
    expect(n).toBe(3); // nothing left to remove
  });

  it('stops listening after dispose', async () => {
    const { bus, sim, h } = setup({ first: ack(0), events: [] });
    await flush();
    h.dispose();
    bus.event(`EVT STATION ${LP1}`);
    bus.connect();
    await flush();
    expect(sim.boxes.size).toBe(0);
    expect(bus.sent).toEqual(['STN']);
  });
});

describe("the controller's solid volumes and obstacles (STN of a controller that checks motions against the cell)", () => {
  const VOL = 'LP1 kind=load_port x=294.449 y=-170 z=20 yaw=-30 slots=25 pitch=10 approach=220 stroke=6 speed=60 interlock=14 posture=any mouth=160 depth=360 width=340 bottom=10 top=290 opening=70';

  it('reads the volume keys and draws the box from them, not from its own sizes', () => {
    const s = parseStationLine(VOL);
    expect(s?.volume).toEqual({ mouth: 160, depth: 360, width: 340, bottom: 10, top: 290, opening: 70 });
    const spec = stationSpec(s!);
    // Centre 360/2 - 160 = 20 mm into the station from the seat, along yaw -30°.
    expect(spec.x).toBeCloseTo(294.449 + 20 * Math.cos(-Math.PI / 6), 6);
    expect(spec.y).toBeCloseTo(-170 + 20 * Math.sin(-Math.PI / 6), 6);
    expect(spec).toMatchObject({ z: 10, yaw: -30, depth: 360, width: 340, height: 280, opening: 70 });
  });

  it('keeps its own drawing when a volume key is missing or makes no box', () => {
    expect(parseStationLine(VOL.replace(' opening=70', ''))?.volume).toBeNull();
    expect(parseStationLine(VOL.replace('top=290', 'top=5'))?.volume).toBeNull();
    expect(parseStationLine(VOL.replace('width=340', 'width=x'))?.volume).toBeNull();
    const plain = stationSpec(parseStationLine(LP1)!);
    expect(plain.opening).toBeUndefined();
  });

  it('reads box and cylinder obstacles, and refuses malformed ones', () => {
    expect(parseObstacleLine('wall kind=box x=0 y=-420 yaw=15 depth=900 width=40 bottom=-300 top=400')).toEqual({
      name: 'wall', kind: 'box', x: 0, y: -420, yaw: 15, depth: 900, width: 40, bottom: -300, top: 400,
    });
    expect(parseObstacleLine('column kind=cylinder x=-300 y=300 radius=60 bottom=-300 top=400')).toEqual({
      name: 'column', kind: 'cylinder', x: -300, y: 300, radius: 60, bottom: -300, top: 400,
    });
    for (const bad of ['', 'kind=box x=0', 'wall kind=cone x=0 y=0 bottom=0 top=1', 'wall kind=box x=0 y=0 depth=0 width=1 bottom=0 top=1',
      'c kind=cylinder x=0 y=0 radius=-1 bottom=0 top=1', 'c kind=cylinder x=0 y=0 radius=5 bottom=3 top=1']) {
      expect(parseObstacleLine(bad), bad).toBeNull();
    }
  });
});
