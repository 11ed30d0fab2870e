import { afterEach, beforeEach, describe, expect, it, vi } from 'vitest';
import type { SimSample } from './bus';
import { Connection, defaultUrl, type SocketLike } from './connection';
import { createWaferStore } from '../cell/wafers';

class FakeSocket implements SocketLike {
  binaryType = 'blob';
  readyState = 0;
  onopen: ((ev: unknown) => void) | null = null;
  onclose: ((ev: unknown) => void) | null = null;
  onerror: ((ev: unknown) => void) | null = null;
  onmessage: ((ev: { data: unknown }) => void) | null = null;
  sent: string[] = [];
  closed = false;
  constructor(readonly url: string) {}
  send(data: string): void {
    if (this.readyState !== 1) throw new Error('not open');
    this.sent.push(data);
  }
  close(): void {
    this.closed = true;
    this.readyState = 3;
  }
  // server side
  open(): void {
    this.readyState = 1;
    this.onopen?.({});
  }
  recv(...lines: string[]): void {
    for (const l of lines) this.onmessage?.({ data: l });
  }
  recvBinary(buf: ArrayBuffer): void {
    this.onmessage?.({ data: buf });
  }
  drop(): void {
    this.readyState = 3;
    this.onclose?.({});
  }
  /** Lines sent so far (frames split at LF). */
  lines(): string[] {
    return this.sent.flatMap((f) => f.split('\n'));
  }
}

const flush = async (): Promise<void> => {
  for (let i = 0; i < 10; i++) await Promise.resolve();
};

describe('Connection', () => {
  let sockets: FakeSocket[];
  let conn: Connection;
  let samples: SimSample[];
  const fakeSample = { seq: 1 } as unknown as SimSample;

  function sock(): FakeSocket {
    return sockets[sockets.length - 1];
  }

  /** Open the socket, say the controller is up, answer the greeting. */
  function up(): FakeSocket {
    const s = sock();
    s.open();
    s.recv('EVT UI CONNECTED /tmp/wrc/wrc.sock');
    return s;
  }

  beforeEach(() => {
    vi.useFakeTimers();
    sockets = [];
    samples = [];
    conn = new Connection('ws://h/ws', {
      socket: (u) => {
        const s = new FakeSocket(u);
        sockets.push(s);
        return s;
      },
      decode: (buf) => (buf.byteLength === 8 ? fakeSample : null),
    });
    conn.onSample((s) => samples.push(s));
  });

  afterEach(() => {
    conn.close();
    vi.useRealTimers();
  });

  it('is connected only after EVT UI CONNECTED, then subscribes and asks ROBOT and IO', () => {
    const states: [boolean, string][] = [];
    conn.onConnection((c, d) => states.push([c, d]));
    expect(sockets).toHaveLength(1);
    expect(sock().url).toBe('ws://h/ws');
    sock().open();
    expect(conn.connected()).toBe(false);
    expect(sock().binaryType).toBe('arraybuffer');
    sock().recv('EVT UI CONNECTED /tmp/wrc/wrc.sock');
    expect(conn.connected()).toBe(true);
    expect(states.at(-1)).toEqual([true, '/tmp/wrc/wrc.sock']);
    expect(sock().lines()).toEqual(['1 SUBSCRIBE', '2 ROBOT', '3 IO']);
  });

  it('learns the robot from the ROBOT reply and its EVT AXIS lines', async () => {
    const s = up();
    const robots: string[] = [];
    conn.onRobot((r) => robots.push(r.name));
    s.recv(
      'ACK 1',
      'EVT AXIS 1 name=j1 role=shoulder unit=deg ppu=1000 min=-180 max=180 home=-75',
      'EVT STATUS state=IDLE homed=0 speed=100 owner=none err=0 j=0,0,0,0 x=400 y=0 z=0 yaw=0',
      'EVT AXIS 2 name=z role=z unit=mm ppu=1000 min=0 max=300 home=0',
      'ACK 2 name=r2 link1=200 link2=200 hand=0 axes=2 period_ms=10 inputs=32 outputs=32',
      'ACK 3 in=00000001 out=00000008',
    );
    await flush();
    expect(robots).toEqual(['r2']);
    expect(conn.robot()?.axes.map((a) => a.name)).toEqual(['j1', 'z']);
    expect(conn.io()).toEqual({ inputs: 1, outputs: 8 });
    s.recv('EVT INPUT 4 1');
    expect(conn.io()).toEqual({ inputs: 0x11, outputs: 8 });
  });

  it('matches first replies by id and resolves the final INF/ABS', async () => {
    const s = up();
    s.recv('ACK 1', 'ACK 2', 'ACK 3 in=0 out=0');
    const home = conn.request('HOME');
    const status = conn.request('STATUS');
    expect(s.lines().slice(-2)).toEqual(['4 HOME', '5 STATUS']);
    s.recv('ACK 4', 'EVT STATE MOVING', 'ACK 5 state=MOVING homed=0 speed=100 owner=none err=0');
    const h = await home;
    expect(h.first).toMatchObject({ kind: 'ACK', id: 4 });
    expect(h.final).not.toBeNull();
    expect(h.events).toEqual([]); // the event came after HOME's ACK
    const st = await status;
    expect(st.first).toMatchObject({ kind: 'ACK', fields: { state: 'MOVING' } });
    expect(st.final).toBeNull();
    expect(st.events).toEqual(['STATE MOVING']);
    s.recv('INF 4', 'EVT STATE IDLE');
    await expect(h.final).resolves.toMatchObject({ kind: 'INF', id: 4 });
  });

  it('gives requester-only events to the request of their verb, even when replies overtake', async () => {
    const s = up(); // the greeting: 1 SUBSCRIBE, 2 ROBOT, 3 IO
    const status = conn.request('STATUS'); // 4
    const robot = conn.request('ROBOT'); // 5
    const up2 = conn.upload('p', 'PRINT X'); // 6
    const axis = (n: number) => `EVT AXIS ${n} name=j${n} role=shoulder unit=deg ppu=1000 min=-180 max=180 home=0`;
    s.recv(
      'ACK 1',
      axis(1),
      axis(2),
      'EVT CONTROL gui1',
      'EVT DIAG p.wrl:1:7: error: unknown variable X',
      'ACK 2 name=r link1=200 link2=200 hand=0 axes=2 period_ms=10 inputs=32 outputs=32',
      axis(1),
      'ACK 5 name=r link1=200 link2=200 hand=0 axes=1 period_ms=10 inputs=32 outputs=32',
      'NAK 6 126 p: 1 error; first: 1:7 unknown variable X',
      'ACK 4 state=IDLE homed=0 speed=100 owner=none err=0',
      'ACK 3 in=0 out=0',
    );
    const [st, rb, u] = await Promise.all([status, robot, up2]);
    expect(st.events).toEqual(['CONTROL gui1']);
    expect(rb.events).toEqual(['CONTROL gui1', axis(1).slice(4)]);
    expect(u.events).toEqual(['CONTROL gui1', 'DIAG p.wrl:1:7: error: unknown variable X']);
    await flush();
    expect(conn.robot()?.axes.map((a) => a.name)).toEqual(['j1', 'j2']);
  });

  it("gives VARS its EVT VAR lines and POINTS its EVT POINT lines, and every listener the points", async () => {
    const s = up();
    s.recv('ACK 1', 'ACK 2', 'ACK 3 in=0 out=0');
    const heard: string[] = [];
    conn.onEvent((name, body) => heard.push(`${name} ${body}`));
    const vars = conn.request('VARS COUNT P'); // 4
    const points = conn.request('POINTS demo'); // 5
    s.recv(
      'EVT VAR COUNT number 3',
      'EVT POINT demo SAFE pose 250 0 10 0',
      'EVT VAR P pose POSE(250, 0, 10, 0)',
      'ACK 4 vars=2',
      'ACK 5 points=1',
    );
    const [v, p] = await Promise.all([vars, points]);
    expect(v.events).toEqual(['VAR COUNT number 3', 'VAR P pose POSE(250, 0, 10, 0)']);
    expect(p.events).toEqual(['POINT demo SAFE pose 250 0 10 0']);
    expect(heard).toContain('POINT demo SAFE pose 250 0 10 0');
  });

  it('gives RECOVERY its EVT RECOVERY lines, not a WAFERS asked beside it; every listener hears them', async () => {
    const s = up();
    s.recv('ACK 1', 'ACK 2', 'ACK 3 in=0 out=0');
    const heard: string[] = [];
    conn.onEvent((name, body) => heard.push(`${name} ${body}`));
    const wafers = conn.request('WAFERS'); // 4
    const recovery = conn.request('RECOVERY'); // 5
    s.recv(
      'EVT RECOVERY hand x=0 y=400 z=0 yaw=0 inside=-',
      'EVT RECOVERY uncertain hand W1',
      'ACK 4 hand=W1? LP1=-x25',
      'ACK 5 uncertain=1 inside=-',
    );
    const [w, r] = await Promise.all([wafers, recovery]);
    expect(w.events).toEqual([]);
    expect(r.events).toEqual(['RECOVERY hand x=0 y=400 z=0 yaw=0 inside=-', 'RECOVERY uncertain hand W1']);
    expect(heard).toContain('RECOVERY uncertain hand W1');
  });

  it('gives no final to a NAK, and ABS with code and text', async () => {
    const s = up();
    const a = conn.request('MOVJ 0 90 -90 10');
    s.recv('NAK 4 110 not homed; send HOME first');
    const r = await a;
    expect(r.first).toMatchObject({ kind: 'NAK', code: 110, text: 'not homed; send HOME first' });
    expect(r.final).toBeNull();
    const b = conn.request('MOVL 300 0 0 0');
    s.recv('ACK 5');
    const rb = await b;
    s.recv('ABS 5 201 emergency stop');
    await expect(rb.final).resolves.toMatchObject({ kind: 'ABS', code: 201, text: 'emergency stop' });
  });

  it('hands an id-less NAK to the oldest waiting request', async () => {
    const s = up();
    s.recv('ACK 1', 'ACK 2', 'ACK 3 in=0 out=0');
    const a = conn.request('STATUS');
    s.recv('NAK 103 line of 300 bytes is longer than the limit of 256 bytes; nothing was done');
    await expect(a).resolves.toMatchObject({ first: { kind: 'NAK', id: 4, code: 103 } });
  });

  it('uploads text lines and collects EVT DIAG before the reply', async () => {
    const s = up();
    s.recv('ACK 1', 'ACK 2', 'ACK 3 in=0 out=0');
    const u = conn.upload('demo', 'HOME\nPRINT TOTAL\n');
    expect(s.sent.at(-1)).toBe('4 UPLOAD demo\nHOME\nPRINT TOTAL\n.');
    s.recv(
      'EVT DIAG demo.wrl:2:7: error: TOTAL is used before any assignment',
      'NAK 4 126 demo: 1 error; first: 2:7 TOTAL is used before any assignment',
    );
    const r = await u;
    expect(r.first).toMatchObject({ kind: 'NAK', code: 126 });
    expect(r.events).toEqual(['DIAG demo.wrl:2:7: error: TOTAL is used before any assignment']);
    await expect(conn.upload('x', 'HOME\n.\n')).rejects.toThrow(/lone/);
  });

  it('passes events to listeners and decodes binary frames', () => {
    const s = up();
    const evs: string[] = [];
    conn.onEvent((n, b) => evs.push(`${n}|${b}`));
    s.recv('EVT PRINT hello world', 'EVT STATE IDLE');
    expect(evs).toEqual(['PRINT|hello world', 'STATE|IDLE']);
    s.recvBinary(new ArrayBuffer(8));
    s.recvBinary(new ArrayBuffer(9)); // invalid: dropped
    expect(samples).toEqual([fakeSample]);
  });

  it('splits a text frame with several lines', async () => {
    const s = up();
    const a = conn.request('STATUS');
    s.recv('ACK 1\nACK 2\nACK 3 in=0 out=0\nACK 4 state=IDLE');
    await expect(a).resolves.toMatchObject({ first: { id: 4 } });
  });

  it('refuses requests while disconnected', async () => {
    await expect(conn.request('STATUS')).rejects.toThrow(/not connected/);
    sock().open();
    await expect(conn.request('STATUS')).rejects.toThrow(/not connected/);
  });

  it('fails pending requests and finals when the controller is lost', async () => {
    const s = up();
    s.recv('ACK 1', 'ACK 2', 'ACK 3 in=0 out=0');
    const home = conn.request('HOME');
    s.recv('ACK 4');
    const h = await home;
    const st = conn.request('STATUS');
    const states: boolean[] = [];
    conn.onConnection((c) => states.push(c));
    s.recv('EVT UI DISCONNECTED controller closed the connection');
    expect(conn.connected()).toBe(false);
    await expect(st).rejects.toThrow(/disconnected/);
    await expect(h.final).rejects.toThrow(/disconnected/);
    expect(states).toEqual([false]);
    // The controller comes back on the same socket: greeting again, with fresh ids.
    s.recv('EVT UI CONNECTED /tmp/wrc/wrc.sock');
    expect(conn.connected()).toBe(true);
    expect(s.lines().slice(-3)).toEqual(['6 SUBSCRIBE', '7 ROBOT', '8 IO']);
  });

  it('reconnects every second after the socket closes', async () => {
    const s = up();
    const pending = conn.request('STATUS');
    const states: [boolean, string][] = [];
    conn.onConnection((c, d) => states.push([c, d]));
    s.drop();
    await expect(pending).rejects.toThrow(/disconnected/);
    expect(conn.connected()).toBe(false);
    expect(states[0][0]).toBe(false);
    expect(sockets).toHaveLength(1);
    vi.advanceTimersByTime(999);
    expect(sockets).toHaveLength(1);
    vi.advanceTimersByTime(1);
    expect(sockets).toHaveLength(2);
    // The new socket fails too: another try a second later.
    sock().drop();
    vi.advanceTimersByTime(1000);
    expect(sockets).toHaveLength(3);
    up();
    expect(conn.connected()).toBe(true);
    expect(sock().lines()[0]).toMatch(/^\d+ SUBSCRIBE$/);
  });

  it('times out a request without a reply', async () => {
    up();
    const p = conn.request('STATUS');
    vi.advanceTimersByTime(30_000);
    await expect(p).rejects.toThrow(/no reply to STATUS/);
  });

  it('hands a split WAFERS reply (EVT WAFER parts, then ACK parts=n) to the wafer store, then follows EVT WAFER', async () => {
    const store = createWaferStore(conn, () => undefined);
    const s = up(); // the greeting: 1 SUBSCRIBE, 2 ROBOT, 3 IO; then the store's 4 WAFERS
    expect(s.lines()).toEqual(['1 SUBSCRIBE', '2 ROBOT', '3 IO', '4 WAFERS']);
    s.recv(
      'ACK 1',
      'EVT WAFER hand=W3',
      'EVT STATE IDLE',
      'EVT WAFER LP1=W1,W2,-,W4..W25',
      'EVT WAFER LP2=-x25',
      'EVT WAFER pending=get:LP2.1:W3',
      'ACK 4 parts=4',
    );
    await flush();
    const m = store.state().map;
    expect(store.state().available).toBe(true);
    expect(m.hand).toBe('W3');
    expect([...m.stations.keys()]).toEqual(['LP1', 'LP2']);
    expect(m.stations.get('LP1')).toHaveLength(25);
    expect(m.pending).toEqual({ kind: 'get', blade: 'A', station: 'LP2', slot: 1, wafer: 'W3' });
    s.recv('EVT WAFER pending=-', 'EVT WAFER hand=-', 'EVT WAFER LP2=W3,-x24');
    expect(store.state().map.pending).toBeNull();
    expect(store.state().map.hand).toBeNull();
    expect(store.state().map.stations.get('LP2')?.[0]).toEqual({ state: 'wafer', wafer: 'W3' });
    store.dispose();
  });

  it('does not reconnect after close()', () => {
    up();
    conn.close();
    vi.advanceTimersByTime(5000);
    expect(sockets).toHaveLength(1);
  });
});

describe('defaultUrl', () => {
  it('uses the page host and token', () => {
    expect(defaultUrl({ protocol: 'http:', host: '127.0.0.1:8080', search: '' })).toBe('ws://127.0.0.1:8080/ws');
    expect(defaultUrl({ protocol: 'https:', host: 'cell:8443', search: '?token=a b' })).toBe('wss://cell:8443/ws?token=a%20b');
  });
});
