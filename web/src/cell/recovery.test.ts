import { describe, expect, it } from 'vitest';
import type { Bus, FirstReply, RobotInfo } from '../protocol/bus';
import {
  createRecoveryStore,
  parsePlace,
  parseRecoveryLine,
  placeText,
  placeWords,
  recoveryFromReply,
  recoveryNeeded,
  uncertainWafers,
  type RecoveryState,
} from './recovery';

/** What the controller writes after a PUT LP2 1 that a power loss cut during the line in. */
const NOTE =
  'PUT LP2 1 (W1) was interrupted during step 2 (the approach and the straight line in); the vacuum is off, so its sensor cannot tell: the vacuum went off before the release at the seat was done (a power loss): the wafer may be on the blade, in the slot or fallen';
const REPLY = [
  `RECOVERY note ${NOTE}`,
  'RECOVERY hand x=183.27 y=105.81 z=31 yaw=30 inside=LP2',
  'RECOVERY uncertain LP2.1 W1',
  'RECOVERY uncertain hand W1',
  'RECOVERY next RETRACT (or HOME) out of LP2, SENSE, MAP LP2, or CONFIRM what an operator sees',
];

describe('parsePlace, placeText, placeWords', () => {
  it('read a slot, the hand and blade B, and write them back', () => {
    for (const t of ['LP2.1', 'BF1.5', 'hand', 'hand.B']) expect(placeText(parsePlace(t)!)).toBe(t);
    expect(parsePlace('hand.A')).toEqual({ kind: 'blade', blade: 'A' });
    expect(placeWords(parsePlace('LP2.1')!)).toBe('LP2 slot 1');
    expect(placeWords(parsePlace('hand')!)).toBe('the hand');
    expect(placeWords(parsePlace('hand.B')!)).toBe('blade B');
  });

  it('refuses anything else', () => {
    for (const t of ['', 'LP2', 'LP2.0', 'LP2.x', 'LP2.1.2', 'hand.C', '.1', 'LP 2.1']) expect(parsePlace(t), t).toBeNull();
  });
});

describe('parseRecoveryLine', () => {
  it('reads the report lines', () => {
    expect(parseRecoveryLine(REPLY[0])).toEqual({ kind: 'note', text: NOTE });
    expect(parseRecoveryLine(REPLY[1])).toEqual({
      kind: 'hand',
      hand: { x: 183.27, y: 105.81, z: 31, yaw: 30, inside: 'LP2' },
    });
    expect(parseRecoveryLine('hand x=0 y=400 z=0 yaw=0 inside=-')).toEqual({
      kind: 'hand',
      hand: { x: 0, y: 400, z: 0, yaw: 0, inside: null },
    });
    expect(parseRecoveryLine(REPLY[2])).toEqual({ kind: 'uncertain', place: { kind: 'slot', station: 'LP2', slot: 1 }, wafer: 'W1' });
    expect(parseRecoveryLine('uncertain hand.B w07')).toEqual({ kind: 'uncertain', place: { kind: 'blade', blade: 'B' }, wafer: 'W7' });
    expect(parseRecoveryLine(REPLY[4])).toEqual({
      kind: 'next',
      items: ['RETRACT (or HOME) out of LP2', 'SENSE', 'MAP LP2', 'or CONFIRM what an operator sees'],
    });
  });

  it('takes any other line for what an action did', () => {
    for (const t of ['retracted out of LP2', 'SENSE: W1 is on the hand (vacuum sensor)', 'confirmed W1 is at LP2.1']) {
      expect(parseRecoveryLine(`RECOVERY ${t}`)).toEqual({ kind: 'action', text: t });
    }
  });

  it('refuses a malformed hand or uncertain line', () => {
    for (const t of [
      'hand x=1 y=2 z=3 inside=-',
      'hand x=a y=2 z=3 yaw=4 inside=-',
      'hand x=1 y=2 z=3 yaw=4',
      'uncertain LP2.1',
      'uncertain LP2.1 W1 W2',
      'uncertain LP2 W1',
      'uncertain LP2.1 X1',
    ]) {
      expect(parseRecoveryLine(t), t).toBeNull();
    }
  });
});

describe('recoveryFromReply', () => {
  it('reads the whole report', () => {
    const { report, bad } = recoveryFromReply('ACK 7 uncertain=2 inside=LP2', REPLY);
    expect(bad).toEqual([]);
    expect(report.note).toBe(NOTE);
    expect(report.inside).toBe('LP2');
    expect(report.hand).toMatchObject({ x: 183.27, inside: 'LP2' });
    expect(report.uncertain.map((u) => `${placeText(u.place)} ${u.wafer}`)).toEqual(['LP2.1 W1', 'hand W1']);
    expect(report.next).toHaveLength(4);
    expect(report.count).toBe(2);
    expect(recoveryNeeded(report)).toBe(true);
    expect(uncertainWafers(report)).toEqual(['W1']);
  });

  it('is nothing to recover once everything is settled and the hand is out', () => {
    const { report } = recoveryFromReply('ACK 9 uncertain=0 inside=-', ['RECOVERY hand x=0 y=400 z=0 yaw=0 inside=-']);
    expect(report).toMatchObject({ note: null, inside: null, uncertain: [], next: [], count: 0 });
    expect(recoveryNeeded(report)).toBe(false);
    expect(recoveryNeeded(null)).toBe(false);
  });

  it('the hand inside a station alone needs recovery', () => {
    const { report } = recoveryFromReply('ACK 9 uncertain=0 inside=PM1', ['RECOVERY hand x=1 y=2 z=3 yaw=4 inside=PM1']);
    expect(recoveryNeeded(report)).toBe(true);
  });

  it("keeps only the reply's own lines: an action's line and a start-up's broadcast before it are left out", () => {
    const events = [
      'WAFER hand=W1?',
      'RECOVERY note an older note',
      'RECOVERY hand x=1 y=1 z=1 yaw=1 inside=LP2',
      'RECOVERY uncertain hand W1',
      'RECOVERY retracted out of LP2',
      'RECOVERY hand x=0 y=400 z=0 yaw=0 inside=-',
      'RECOVERY uncertain hand W1',
      'RECOVERY next SENSE, or CONFIRM what an operator sees',
    ];
    const { report, bad } = recoveryFromReply('ACK 3 uncertain=1 inside=-', events);
    expect(bad).toEqual([]);
    expect(report.note).toBeNull();
    expect(report.inside).toBeNull();
    expect(report.uncertain).toHaveLength(1);
    expect(report.next).toEqual(['SENSE', 'or CONFIRM what an operator sees']);
  });

  it('says when a line is malformed or the count is not the ACK’s', () => {
    const { report, bad } = recoveryFromReply('ACK 3 uncertain=2 inside=-', [
      'RECOVERY hand x=0 y=400 z=0 yaw=0 inside=-',
      'RECOVERY uncertain LP2 W1',
      'RECOVERY uncertain hand W1',
    ]);
    expect(report.uncertain).toHaveLength(1);
    expect(bad).toEqual(['RECOVERY uncertain LP2 W1', 'uncertain=2 but 1 uncertain line came']);
  });

  it('takes the hand line’s inside= when the ACK has none', () => {
    const { report } = recoveryFromReply('ACK 3', ['RECOVERY hand x=1 y=2 z=3 yaw=4 inside=LP1']);
    expect(report.inside).toBe('LP1');
    expect(report.count).toBeNull();
  });
});

// ---- the store, with a fake bus ----

type Reply = { first: FirstReply; events: string[] };

class FakeBus implements Bus {
  up = true;
  sent: string[] = [];
  replies: (Reply | Error)[] = [];
  /** Lines the fake "controller" sends as events while a RECOVERY is answered (its own lines). */
  echo = true;
  private conn: ((c: boolean, d: string) => void)[] = [];
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
  onRobot() {
    return () => undefined;
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
    await Promise.resolve();
    const r = this.replies.shift() ?? new Error('no reply');
    if (r instanceof Error) throw r;
    // The reply's lines are events as well (EVT RECOVERY to the requester) before its ACK.
    if (this.echo) for (const e of r.events) this.event(`EVT ${e}`);
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
/**
 * Let the store handle what it was sent. The fake bus answers in microtasks and the store
 * handles a reply (and any request it then makes) in microtasks too, with no timer anywhere:
 * a macrotask runs only once all of them have run, so one turn is enough, on any machine.
 */
const flush = () => new Promise((r) => setTimeout(r, 0));
const SETTLED: Reply = { first: ack('uncertain=0 inside=-'), events: ['RECOVERY hand x=0 y=400 z=0 yaw=0 inside=-'] };
const UNSETTLED: Reply = { first: ack('uncertain=2 inside=LP2'), events: REPLY };

function setup(replies: (Reply | Error)[], connected = true) {
  const bus = new FakeBus();
  bus.up = connected;
  bus.replies = [...replies];
  const warnings: string[] = [];
  const store = createRecoveryStore(bus, (m) => warnings.push(m));
  const seen: RecoveryState[] = [];
  store.onChange((s) => seen.push(s));
  return { bus, store, warnings, seen };
}

describe('createRecoveryStore', () => {
  it('asks RECOVERY on connecting and holds the report; its own lines do not make it ask again', async () => {
    const { bus, store } = setup([UNSETTLED], false);
    expect(bus.sent).toEqual([]);
    bus.connect();
    await flush();
    expect(bus.sent).toEqual(['RECOVERY']);
    expect(store.state().available).toBe(true);
    expect(store.state().report?.uncertain).toHaveLength(2);
    expect(store.state().done).toEqual([]);
  });

  it("asks again on an action's line, and keeps what was done", async () => {
    const { bus, store } = setup([UNSETTLED, SETTLED]);
    await flush();
    bus.event('EVT RECOVERY retracted out of LP2');
    await flush();
    expect(bus.sent).toEqual(['RECOVERY', 'RECOVERY']);
    expect(store.state().done).toEqual(['retracted out of LP2']);
    expect(recoveryNeeded(store.state().report)).toBe(false);
  });

  it('asks on a start-up broadcast and on alarm 216, not on other alarms', async () => {
    const { bus } = setup([SETTLED, UNSETTLED, UNSETTLED]);
    await flush();
    bus.event('EVT ERROR 203 following error on axis j2');
    await flush();
    expect(bus.sent).toHaveLength(1);
    bus.event('EVT RECOVERY hand x=1 y=2 z=3 yaw=4 inside=LP2');
    await flush();
    expect(bus.sent).toHaveLength(2);
    bus.event('EVT ERROR 216 a transfer was interrupted by a power loss; RECOVERY says what is uncertain');
    await flush();
    expect(bus.sent).toHaveLength(3);
  });

  it('asks on a change of the wafer map only while something is (or becomes) uncertain', async () => {
    const { bus } = setup([SETTLED, UNSETTLED, SETTLED]);
    await flush();
    bus.event('EVT WAFER LP1=W1..W25');
    await flush();
    expect(bus.sent).toHaveLength(1);
    bus.event('EVT WAFER hand=W1?');
    await flush();
    expect(bus.sent).toHaveLength(2);
    bus.event('EVT WAFER hand=-'); // while the report is unsettled
    await flush();
    expect(bus.sent).toHaveLength(3);
  });

  it('asks once more, not twice, when asked while a reply is on its way', async () => {
    const { bus, store } = setup([UNSETTLED, UNSETTLED, SETTLED]);
    const a = store.refresh();
    const b = store.refresh();
    const c = store.refresh();
    await Promise.all([a, b, c]);
    await flush();
    expect(bus.sent).toEqual(['RECOVERY', 'RECOVERY']);
  });

  it('says so when the controller refuses RECOVERY (no cell, or an older controller)', async () => {
    const nak: FirstReply = { kind: 'NAK', id: 1, code: 100, text: 'unknown verb RECOVERY; HELP lists the verbs', line: '' };
    const { store } = setup([{ first: nak, events: [] }]);
    await flush();
    expect(store.state().available).toBe(false);
    expect(store.state().refusal).toBe('100 unknown verb RECOVERY; HELP lists the verbs');
  });

  it('warns about malformed lines and uses the rest', async () => {
    const { store, warnings } = setup([{ first: ack('uncertain=1 inside=-'), events: ['RECOVERY hand x=0 y=1 z=2 yaw=3 inside=-', 'RECOVERY uncertain ?? W1'] }]);
    await flush();
    expect(store.state().report?.hand?.y).toBe(1);
    expect(warnings).toHaveLength(2);
  });

  it('stops asking once disposed', async () => {
    const { bus, store } = setup([SETTLED, SETTLED]);
    await flush();
    store.dispose();
    bus.event('EVT RECOVERY retracted out of LP2');
    await flush();
    expect(bus.sent).toHaveLength(1);
  });
});
