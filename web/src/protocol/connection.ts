// The one WebSocket to `wrc ui` (docs/gui.md), shared by every panel as a `Bus`.
//
// - Reconnects every second while the socket is closed.
// - "Connected" means: the socket is open AND `wrc ui` said `EVT UI CONNECTED …`. Then it
//   sends `SUBSCRIBE`, `ROBOT` and `IO` (each with an id), and learns the robot again.
// - Requests get ids; first replies (ACK/NAK) and final replies (INF/ABS) are matched by id.
//   An id-less first reply (`NAK 103`) belongs to the oldest request still waiting; the
//   requester-only events before a first reply (`EVT AXIS`, `EVT SIGNAL`, `EVT TASK`, `EVT DIAG`,
//   `EVT VAR`, `EVT POINT`, `EVT RECOVERY`, `EVT OBSTACLE`) to the oldest waiting request of the verb that causes them (see
//   `collect`).
// - Binary frames are simulator datagrams, decoded by `decodeSample`.

import type {
  Bus,
  FinalReply,
  FirstReply,
  RobotInfo,
  SimSample,
  Unsubscribe,
} from './bus';
import {
  IdAllocator,
  completesLater,
  formatRequest,
  formatUpload,
  parseIo,
  parseLine,
  robotFromReply,
} from './protocol';
import { decodeSample } from './stream';

/** What the connection needs of a WebSocket (the browser's, or a fake in tests). */
export interface SocketLike {
  binaryType: string;
  readonly readyState: number;
  onopen: ((ev: unknown) => void) | null;
  onclose: ((ev: unknown) => void) | null;
  onerror: ((ev: unknown) => void) | null;
  onmessage: ((ev: { data: unknown }) => void) | null;
  send(data: string): void;
  close(): void;
}

export interface ConnectionOptions {
  /** Makes a socket for a URL; default: `new WebSocket(url)`. */
  socket?: (url: string) => SocketLike;
  /** Decodes a binary frame; default: `decodeSample` of stream.ts. */
  decode?: (buf: ArrayBuffer) => SimSample | null;
  /** Delay before reconnecting [ms]; default 1000. */
  reconnectMs?: number;
  /** A first reply that has not come after this long rejects the request [ms]; default 30000. */
  replyTimeoutMs?: number;
  /** Timers (tests pass fakes through vitest's fake timers instead; kept for completeness). */
  setTimeout?: (fn: () => void, ms: number) => unknown;
  clearTimeout?: (h: unknown) => void;
}

const OPEN = 1;

/** Events sent only to the requester, before the first reply of these verbs. */
const REQUESTER_EVENTS: Record<string, string[]> = {
  AXIS: ['ROBOT'],
  SIGNAL: ['ROBOT'],
  // Sent with a STN reply only (a station's line also after TEACH, to everyone: not here).
  OBSTACLE: ['STN'],
  TASK: ['TASKS'],
  DIAG: ['UPLOAD', 'RUN'],
  VAR: ['VARS'],
  // Also sent to everyone when a point changes; a POINTS reply is told those too.
  POINT: ['POINTS'],
  // Also sent to everyone after a start-up that found something and after each recovery
  // action; a RECOVERY reply is told those too (recovery.ts picks its own lines).
  RECOVERY: ['RECOVERY'],
};

interface Pending {
  id: number;
  verb: string;
  events: string[];
  resolve: (r: { first: FirstReply; final: Promise<FinalReply> | null; events: string[] }) => void;
  reject: (e: Error) => void;
  wantsFinal: boolean;
  timer: unknown;
}

interface PendingFinal {
  resolve: (r: FinalReply) => void;
  reject: (e: Error) => void;
}

type Listener<A extends unknown[]> = (...a: A) => void;

class Listeners<A extends unknown[]> {
  private set = new Set<Listener<A>>();
  add(cb: Listener<A>): Unsubscribe {
    this.set.add(cb);
    return () => {
      this.set.delete(cb);
    };
  }
  emit(...a: A): void {
    for (const cb of [...this.set]) {
      try {
        cb(...a);
      } catch (e) {
        console.error('wrc: listener failed', e);
      }
    }
  }
}

/** The default WebSocket URL: `/ws` of the page's host, with the page's `?token=`. */
export function defaultUrl(loc: { protocol: string; host: string; search: string }): string {
  const scheme = loc.protocol === 'https:' ? 'wss:' : 'ws:';
  const token = new URLSearchParams(loc.search).get('token');
  return `${scheme}//${loc.host}/ws${token ? `?token=${encodeURIComponent(token)}` : ''}`;
}

export class Connection implements Bus {
  private ws: SocketLike | null = null;
  private wsOpen = false;
  private ctrlUp = false;
  private detail = 'connecting';
  private robotInfo: RobotInfo | null = null;
  private ioWords: { inputs: number; outputs: number } | null = null;
  private ids = new IdAllocator();
  /** Requests waiting for their first reply, oldest first. */
  private waiting: Pending[] = [];
  private finals = new Map<number, PendingFinal>();
  private stopped = false;
  private reconnectTimer: unknown = null;

  private connL = new Listeners<[boolean, string]>();
  private robotL = new Listeners<[RobotInfo]>();
  private sampleL = new Listeners<[SimSample]>();
  private eventL = new Listeners<[string, string, string]>();

  private readonly makeSocket: (url: string) => SocketLike;
  private readonly decode: (buf: ArrayBuffer) => SimSample | null;
  private readonly reconnectMs: number;
  private readonly replyTimeoutMs: number;
  private readonly setT: (fn: () => void, ms: number) => unknown;
  private readonly clearT: (h: unknown) => void;

  constructor(
    private readonly url: string,
    opts: ConnectionOptions = {},
  ) {
    this.makeSocket = opts.socket ?? ((u) => new WebSocket(u) as unknown as SocketLike);
    this.decode = opts.decode ?? decodeSample;
    this.reconnectMs = opts.reconnectMs ?? 1000;
    this.replyTimeoutMs = opts.replyTimeoutMs ?? 30000;
    this.setT = opts.setTimeout ?? ((fn, ms) => setTimeout(fn, ms));
    this.clearT = opts.clearTimeout ?? ((h) => clearTimeout(h as ReturnType<typeof setTimeout>));
    this.open();
  }

  // ---- Bus ----

  connected(): boolean {
    return this.wsOpen && this.ctrlUp;
  }

  onConnection(cb: (connected: boolean, detail: string) => void): Unsubscribe {
    return this.connL.add(cb);
  }

  robot(): RobotInfo | null {
    return this.robotInfo;
  }

  onRobot(cb: (robot: RobotInfo) => void): Unsubscribe {
    return this.robotL.add(cb);
  }

  onSample(cb: (s: SimSample) => void): Unsubscribe {
    return this.sampleL.add(cb);
  }

  onEvent(cb: (name: string, body: string, line: string) => void): Unsubscribe {
    return this.eventL.add(cb);
  }

  request(line: string): Promise<{ first: FirstReply; final: Promise<FinalReply> | null; events: string[] }> {
    const req = line.trim();
    if (req.includes('\n') || req.includes('\r')) {
      return Promise.reject(new Error('a request is one line'));
    }
    const id = this.ids.next();
    return this.send(id, formatRequest(id, req), req.split(/[ \t]+/)[0].toUpperCase(), completesLater(req));
  }

  upload(name: string, text: string): Promise<{ first: FirstReply; events: string[] }> {
    const id = this.ids.next();
    let frame: string;
    try {
      frame = formatUpload(id, name, text);
    } catch (e) {
      return Promise.reject(e instanceof Error ? e : new Error(String(e)));
    }
    return this.send(id, frame, 'UPLOAD', false).then((r) => ({ first: r.first, events: r.events }));
  }

  // ---- extras (not part of Bus) ----

  /** Description of the connection state (the controller's address, or why it is down). */
  describe(): string {
    return this.detail;
  }

  /** The last `IO` reply (inputs kept up to date by `EVT INPUT`; outputs as last read). */
  io(): { inputs: number; outputs: number } | null {
    return this.ioWords;
  }

  /** Close for good (tests, page unload). */
  close(): void {
    this.stopped = true;
    if (this.reconnectTimer !== null) this.clearT(this.reconnectTimer);
    this.reconnectTimer = null;
    const ws = this.ws;
    this.ws = null;
    if (ws) {
      ws.onopen = ws.onclose = ws.onerror = null;
      ws.onmessage = null;
      try {
        ws.close();
      } catch {
        /* already closed */
      }
    }
    this.lost('closed');
  }

  // ---- internals ----

  private send(
    id: number,
    frame: string,
    verb: string,
    wantsFinal: boolean,
  ): Promise<{ first: FirstReply; final: Promise<FinalReply> | null; events: string[] }> {
    if (!this.connected() || !this.ws || this.ws.readyState !== OPEN) {
      return Promise.reject(new Error(`not connected (${this.detail})`));
    }
    return new Promise((resolve, reject) => {
      const p: Pending = { id, verb, events: [], resolve, reject, wantsFinal, timer: null };
      p.timer = this.setT(() => {
        const i = this.waiting.indexOf(p);
        if (i >= 0) this.waiting.splice(i, 1);
        reject(new Error(`no reply to ${verb} within ${Math.round(this.replyTimeoutMs / 1000)} s`));
      }, this.replyTimeoutMs);
      this.waiting.push(p);
      try {
        this.ws!.send(frame);
      } catch (e) {
        this.waiting.splice(this.waiting.indexOf(p), 1);
        this.clearT(p.timer);
        reject(new Error(`send failed: ${String(e)}`));
      }
    });
  }

  private open(): void {
    if (this.stopped) return;
    this.reconnectTimer = null;
    let ws: SocketLike;
    try {
      ws = this.makeSocket(this.url);
    } catch (e) {
      this.detail = `cannot open ${this.url}: ${String(e)}`;
      this.scheduleReconnect();
      return;
    }
    this.ws = ws;
    ws.binaryType = 'arraybuffer';
    ws.onopen = () => {
      if (this.ws !== ws) return;
      this.wsOpen = true;
      this.detail = 'waiting for the controller';
      this.connL.emit(false, this.detail);
    };
    ws.onmessage = (ev) => {
      if (this.ws !== ws) return;
      this.message(ev.data);
    };
    ws.onerror = () => {
      /* onclose follows */
    };
    ws.onclose = () => {
      if (this.ws !== ws) return;
      this.ws = null;
      const was = this.wsOpen;
      this.wsOpen = false;
      this.lost(was ? 'connection to wrc ui lost' : 'wrc ui not reachable');
      this.scheduleReconnect();
    };
  }

  private scheduleReconnect(): void {
    if (this.stopped || this.reconnectTimer !== null) return;
    this.reconnectTimer = this.setT(() => this.open(), this.reconnectMs);
  }

  /** The controller (or the socket) is gone: fail everything in flight. */
  private lost(detail: string): void {
    const wasUp = this.ctrlUp;
    this.ctrlUp = false;
    this.detail = detail;
    const err = new Error(`disconnected: ${detail}`);
    const waiting = this.waiting;
    this.waiting = [];
    for (const p of waiting) {
      this.clearT(p.timer);
      p.reject(err);
    }
    const finals = [...this.finals.values()];
    this.finals.clear();
    for (const f of finals) f.reject(err);
    if (wasUp || this.wsOpen || detail !== '') this.connL.emit(false, detail);
  }

  private message(data: unknown): void {
    if (typeof data === 'string') {
      for (const l of data.split('\n')) if (l.length > 0) this.line(l);
      return;
    }
    let buf: ArrayBuffer | null = null;
    if (data instanceof ArrayBuffer) buf = data;
    else if (ArrayBuffer.isView(data)) {
      const v = data as ArrayBufferView;
      buf = v.buffer.slice(v.byteOffset, v.byteOffset + v.byteLength) as ArrayBuffer;
    }
    if (!buf) return;
    const s = this.decode(buf);
    if (s) this.sampleL.emit(s);
  }

  private line(text: string): void {
    const l = parseLine(text);
    switch (l.kind) {
      case 'EVT':
        this.event(l.name, l.body, l.line);
        return;
      case 'ACK':
      case 'NAK':
        this.first(l);
        return;
      case 'INF':
      case 'ABS':
        this.final(l);
        return;
      default:
        return;
    }
  }

  private event(name: string, body: string, line: string): void {
    if (name === 'UI') {
      const m = /^(\S+)\s*(.*)$/.exec(body);
      const what = (m?.[1] ?? '').toUpperCase();
      const rest = m?.[2] ?? '';
      if (what === 'CONNECTED') {
        if (this.ctrlUp) this.lost('controller connection re-established');
        this.ctrlUp = true;
        this.detail = rest || 'controller';
        this.greet();
        this.connL.emit(true, this.detail);
      } else if (what === 'DISCONNECTED') {
        this.lost(rest ? `controller lost: ${rest}` : 'controller lost');
      }
      this.eventL.emit(name, body, line);
      return;
    }
    if (name === 'INPUT' && this.ioWords) {
      const m = /^(\d+)\s+([01])/.exec(body);
      if (m) {
        const bit = (1 << Number(m[1])) >>> 0;
        this.ioWords.inputs = m[2] === '1' ? (this.ioWords.inputs | bit) >>> 0 : (this.ioWords.inputs & ~bit) >>> 0;
      }
    }
    this.collect(name, line.replace(/^\s*EVT[ \t]+/i, ''));
    this.eventL.emit(name, body, line);
  }

  /**
   * Give an event line to the requests waiting for their first reply. The requester-only
   * events (`AXIS`, `SIGNAL`, `TASK`, `DIAG`, `VAR`, `POINT`, `RECOVERY`, `OBSTACLE`) go to the oldest waiting request of the verb that causes
   * them (first replies of different verbs may overtake each other: queries answered by other
   * controller threads come back before those of the Command Interpreter); every other event
   * but the status stream goes to every waiting request.
   */
  private collect(name: string, text: string): void {
    if (name === 'STATUS' || this.waiting.length === 0) return;
    const verbs = REQUESTER_EVENTS[name];
    if (verbs) {
      const p = this.waiting.find((w) => verbs.includes(w.verb));
      if (p) p.events.push(text);
      return;
    }
    for (const p of this.waiting) p.events.push(text);
  }

  /** After `EVT UI CONNECTED`: subscribe, learn the robot and the I/O words. */
  private greet(): void {
    this.request('SUBSCRIBE').catch(() => undefined);
    this.request('ROBOT')
      .then(({ first, events }) => {
        if (first.kind !== 'ACK') return;
        this.robotInfo = robotFromReply(first.fields, events);
        this.robotL.emit(this.robotInfo);
      })
      .catch(() => undefined);
    this.request('IO')
      .then(({ first }) => {
        if (first.kind === 'ACK') this.ioWords = parseIo(first.fields);
      })
      .catch(() => undefined);
  }

  private first(l: Extract<ReturnType<typeof parseLine>, { kind: 'ACK' | 'NAK' }>): void {
    const i = l.id === null ? 0 : this.waiting.findIndex((p) => p.id === l.id);
    if (i < 0 || this.waiting.length === 0) return; // not ours (or timed out)
    const p = this.waiting[i];
    this.waiting.splice(i, 1);
    this.clearT(p.timer);
    const id = p.id;
    let first: FirstReply;
    if (l.kind === 'ACK') first = { kind: 'ACK', id, fields: l.fields, line: l.line };
    else first = { kind: 'NAK', id, code: l.code, text: l.text, line: l.line };
    let final: Promise<FinalReply> | null = null;
    if (p.wantsFinal && first.kind === 'ACK') {
      final = new Promise<FinalReply>((resolve, reject) => this.finals.set(id, { resolve, reject }));
      // A final that nobody awaits must not be an unhandled rejection on disconnect.
      final.catch(() => undefined);
    }
    p.resolve({ first, final, events: p.events });
  }

  private final(l: Extract<ReturnType<typeof parseLine>, { kind: 'INF' | 'ABS' }>): void {
    if (l.id === null) return;
    const f = this.finals.get(l.id);
    if (!f) return;
    this.finals.delete(l.id);
    if (l.kind === 'INF') f.resolve({ kind: 'INF', id: l.id, fields: l.fields, line: l.line });
    else f.resolve({ kind: 'ABS', id: l.id, code: l.code, text: l.text, line: l.line });
  }
}
