// The controller as this page knows it: connection, robot, state, position, I/O and who holds
// control, kept from the bus (samples, events, the replies to this page's requests) and shared
// by the header, the Control panel and the Wafers panel. No DOM: listeners are called at most
// once per frame with the whole view.

import type { Bus, FirstReply, RobotInfo, RobotState, SimSample, Unsubscribe } from './bus';
import { frameThrottle } from '../frame-throttle';
import { Listeners } from './listeners';
import { errorText, parseErrorEvent, parseInputEvent, parseIo, parseStatus, verbOf } from './protocol';

/** Everything the header and the Control panel show. */
export interface ControllerView {
  connected: boolean;
  connDetail: string;
  robot: RobotInfo | null;
  state: RobotState | null;
  homed: boolean | null;
  speed: number | null;
  /** Source holding control (`none` when nobody does). */
  owner: string;
  err: number;
  errText: string;
  /** Our own source name (`gui0`), once a CONTROL reply told it. */
  me: string | null;
  inputs: number | null;
  outputs: number | null;
  x: number | null;
  y: number | null;
  z: number | null;
  yaw: number | null;
  positions: number[];
  pulses: number[] | null;
  /** `performance.now()` of the last simulator sample (0: none yet). */
  lastSample: number;
  /** Connections to the controller so far (1 after the first `EVT UI CONNECTED`). */
  epoch: number;
  /**
   * The connection (`epoch`) in which `positions` were last read from the robot (a WHERE or
   * STATUS reply, the status stream or a datagram); 0: never. Fields filled from the robot
   * wait until it equals `epoch`: values from before a reconnection may be stale.
   */
  positionsEpoch: number;
  /** The connection (`epoch`) in which `owner` was last told (STATUS, the status stream, EVT CONTROL); 0: never. */
  ownerEpoch: number;
}

/** Keeps a `ControllerView` up to date from the bus; `onChange` listeners see every change. */
export class ControllerModel {
  readonly v: ControllerView = {
    connected: false,
    connDetail: 'connecting',
    robot: null,
    state: null,
    homed: null,
    speed: null,
    owner: 'none',
    err: 0,
    errText: '',
    me: null,
    inputs: null,
    outputs: null,
    x: null,
    y: null,
    z: null,
    yaw: null,
    positions: [],
    pulses: null,
    lastSample: 0,
    epoch: 0,
    positionsEpoch: 0,
    ownerEpoch: 0,
  };
  private readonly listeners = new Listeners<[ControllerView]>('controller view');
  private notify = frameThrottle(() => {
    this.listeners.emit(this.v);
  });

  constructor(readonly bus: Bus) {
    this.v.connected = bus.connected();
    this.v.robot = bus.robot();
    bus.onConnection((up, detail) => {
      this.v.connected = up;
      this.v.connDetail = detail;
      if (!up) {
        this.v.me = null;
        this.v.state = null;
      } else {
        this.v.epoch++;
        this.refresh();
        this.bus
          .request('WHERE')
          .then(({ first }) => this.noteReply('WHERE', first))
          .catch(() => undefined);
      }
      this.notify();
    });
    bus.onRobot((r) => {
      this.v.robot = r;
      this.notify();
    });
    bus.onSample((s) => this.sample(s));
    bus.onEvent((name, body) => this.event(name, body));
  }

  onChange(cb: (v: ControllerView) => void): Unsubscribe {
    const off = this.listeners.add(cb);
    cb(this.v);
    return off;
  }

  /** May this page command motions? (Nobody or we hold control; the controller checks too.) */
  mayCommand(): boolean {
    return this.v.connected && (this.v.owner === 'none' || (this.v.me !== null && this.v.owner === this.v.me));
  }

  /** Do we hold control? */
  holdsControl(): boolean {
    return this.v.me !== null && this.v.owner === this.v.me;
  }

  /** Learn the reply of a request this page made (CONTROL tells our name, IO the words). */
  noteReply(request: string, first: FirstReply): void {
    if (first.kind !== 'ACK') return;
    const verb = verbOf(request);
    if (verb === 'CONTROL' && first.fields.owner) {
      this.v.me = first.fields.owner;
      this.v.owner = first.fields.owner;
    } else if (verb === 'RELEASE') {
      this.v.owner = first.fields.owner ?? 'none';
    } else if (verb === 'IO') {
      const io = parseIo(first.fields);
      if (io) {
        this.v.inputs = io.inputs;
        this.v.outputs = io.outputs;
      }
    } else if (verb === 'STATUS' || verb === 'WHERE') {
      this.status(first.fields);
      return;
    } else if (verb === 'SPEED' && first.fields.speed) {
      this.v.speed = Number(first.fields.speed);
    }
    this.notify();
  }

  /** Ask STATUS and IO (after connecting and after OUT). */
  refresh(): void {
    for (const q of ['STATUS', 'IO']) {
      this.bus
        .request(q)
        .then(({ first }) => this.noteReply(q, first))
        .catch(() => undefined);
    }
  }

  private sample(s: SimSample): void {
    const v = this.v;
    const now = performance.now();
    // At rest every datagram says the same: nothing to draw (the 300 ms freshness of
    // `lastSample` is kept by the datagrams that do change, and by this one once it ages).
    const same =
      v.positionsEpoch === v.epoch &&
      v.state === s.state &&
      v.homed === s.homed &&
      v.inputs === s.inputs &&
      v.outputs === s.outputs &&
      sameNumbers(v.positions, s.positions) &&
      v.pulses !== null &&
      sameNumbers(v.pulses, s.pulses);
    v.lastSample = now;
    if (same) return;
    v.positionsEpoch = v.epoch;
    v.state = s.state;
    v.homed = s.homed;
    v.inputs = s.inputs;
    v.outputs = s.outputs;
    v.x = s.x;
    v.y = s.y;
    v.z = s.z;
    v.yaw = s.yaw;
    v.positions = s.positions;
    v.pulses = s.pulses;
    this.notify();
  }

  /** What a status line can change, to tell whether one changed anything. */
  private statusKey(): string {
    const v = this.v;
    return `${v.state}|${v.homed}|${v.speed}|${v.owner}|${v.ownerEpoch}|${v.err}|${v.errText}|${v.positionsEpoch}|${v.positions.join(',')}|${v.x}|${v.y}|${v.z}|${v.yaw}`;
  }

  private status(fields: string | Record<string, string>): void {
    const before = this.statusKey();
    const st = parseStatus(fields);
    const v = this.v;
    // Samples are newer and faster; lastSample 0 means none has come yet.
    const fresh = v.lastSample > 0 && performance.now() - v.lastSample < 300;
    if (st.state && !fresh) v.state = st.state;
    if (st.homed !== undefined && !fresh) v.homed = st.homed;
    if (st.speed !== undefined) v.speed = st.speed;
    if (st.owner !== undefined) {
      v.owner = st.owner;
      v.ownerEpoch = v.epoch;
    }
    if (st.err !== undefined) {
      if (st.err === 0) v.errText = '';
      else if (st.err !== v.err || v.errText === '') v.errText = errorText(st.err);
      v.err = st.err;
    }
    if (st.joints) v.positionsEpoch = v.epoch;
    if (!fresh) {
      if (st.joints) {
        v.positions = st.joints;
        const r = v.robot;
        v.pulses = r ? st.joints.map((j, i) => Math.round(j * (r.axes[i]?.ppu ?? 1))) : v.pulses;
      }
      if (st.x !== undefined) v.x = st.x;
      if (st.y !== undefined) v.y = st.y;
      if (st.z !== undefined) v.z = st.z;
      if (st.yaw !== undefined) v.yaw = st.yaw;
    }
    // The status stream repeats itself at rest: nothing to draw then.
    if (this.statusKey() !== before) this.notify();
  }

  private event(name: string, body: string): void {
    const v = this.v;
    switch (name) {
      case 'STATUS':
        this.status(body);
        return;
      case 'STATE': {
        const s = parseStatus(`state=${body.trim()}`).state;
        if (s) v.state = s;
        break;
      }
      case 'CONTROL':
        v.owner = body.trim() || 'none';
        v.ownerEpoch = v.epoch;
        break;
      case 'ERROR': {
        const e = parseErrorEvent(body);
        if (e) {
          v.err = e.code;
          v.errText = `${e.code} ${e.text}`;
        }
        break;
      }
      case 'INPUT': {
        const i = parseInputEvent(body);
        if (i && v.inputs !== null) {
          const bit = (1 << i.n) >>> 0;
          v.inputs = i.on ? (v.inputs | bit) >>> 0 : (v.inputs & ~bit) >>> 0;
        }
        break;
      }
      default:
        return;
    }
    this.notify();
  }
}

function sameNumbers(a: readonly number[], b: readonly number[]): boolean {
  if (a.length !== b.length) return false;
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return false;
  return true;
}

/**
 * Why the RESUME button is disabled, or '' when it is enabled: only a `HELD` motion can be
 * continued, and RESUME needs control like a motion. The controller checks again
 * (`NAK 129 no motion is held`).
 */
export function resumeRefusal(v: Pick<ControllerView, 'connected' | 'state' | 'owner'>, mayCommand: boolean): string {
  if (!v.connected) return 'not connected';
  if (v.state !== 'HELD') return `no motion is held (state ${v.state ?? 'unknown'})`;
  if (!mayCommand) return `control is held by ${v.owner}`;
  return '';
}
