// The contract between the panels and the one connection to `wrc ui` (docs/gui.md).
// Types only: `connection.ts` implements `Bus`; `stream.ts` decodes the simulator datagrams
// into `SimSample`; the panels (control, editor, simulator, plots) only ever see a `Bus`.

/** One axis of the robot, from an `EVT AXIS` line of the `ROBOT` reply. */
export interface AxisInfo {
  /** 1-based axis number, as in `JOG <axis>`. */
  index: number;
  /** Configured name (`j1`, `z`). */
  name: string;
  /** `shoulder`, `elbow`, `wrist`, `z` or `auxiliary`. */
  role: string;
  /** `deg` (rotary) or `mm` (linear). */
  unit: string;
  /** Pulses per unit [pulse/deg or pulse/mm]. */
  ppu: number;
  /** Joint limits [unit]. */
  min: number;
  max: number;
  /** Home position [unit]. */
  home: number;
}

/**
 * A named digital signal, from an `EVT SIGNAL <in|out> <n> <guarded|-> <name…>` line of the
 * `ROBOT` reply (a controller that predates them sends none: signals are then numbers only).
 */
export interface SignalInfo {
  /** `in`: an input (a lamp); `out`: an output (a switch). */
  dir: 'in' | 'out';
  /** Its number, 0 to 31 (`IO`'s bit, `OUT <n>`). */
  n: number;
  /**
   * A guarded output (the hand's vacuum valve, …): switching it while the wafer map says a
   * blade holds a wafer is refused (`NAK 141`) unless the request ends with `FORCE`.
   */
  guarded: boolean;
  /** The configuration's name (`vacuum valve`, `E-stop button`); may contain blanks. */
  name: string;
}

/**
 * The robot, from the `ROBOT` reply (`ACK … name= link1= link2= hand= axes= period_ms=`, and
 * `blade_b=` on a dual-blade robot).
 */
export interface RobotInfo {
  name: string;
  /** Shoulder-to-elbow length [mm]. */
  link1: number;
  /** Elbow-to-wrist length [mm]. */
  link2: number;
  /** Wrist axis to tool centre point [mm]. */
  hand: number;
  /**
   * A dual-blade robot's blade B: the height of its wafer plane above the hand's (the TCP's)
   * [mm], negative below it; it sits on the same wrist and points the same way. Null (or
   * absent, for robots described before blades existed) on a single-hand robot.
   */
  bladeB?: number | null;
  /** Pulse Generator period [ms] (pulses per period in the plots are per this period). */
  periodMs: number;
  /** Number of digital inputs and outputs (32 each). */
  inputs: number;
  outputs: number;
  axes: AxisInfo[];
  /** The named signals (empty from a controller that names none). */
  signals?: SignalInfo[];
}

/**
 * Controller states, as in `STATUS` and the simulator stream. `HELD`: a motion braked by
 * `HOLD` waits on its path for `RESUME`.
 */
export type RobotState = 'IDLE' | 'MOVING' | 'STOPPING' | 'HELD' | 'ERROR' | 'ESTOP';

/** One decoded simulator datagram (docs/simulator-stream.md, version 1). */
export interface SimSample {
  seq: number;
  /** Controller monotonic time [ns] (a JS number: only differences are meaningful). */
  timeNs: number;
  state: RobotState;
  homed: boolean;
  inputs: number;
  outputs: number;
  /** Tool centre point [mm] and hand yaw [deg]. */
  x: number;
  y: number;
  z: number;
  yaw: number;
  /** Axis positions [deg | mm], in configuration order. */
  positions: number[];
  /** Commanded axis positions [pulse]. */
  pulses: number[];
}

/** The first reply to a request: `ACK` (with its key=value pairs) or `NAK` (code and text). */
export type FirstReply =
  | { kind: 'ACK'; id: number; fields: Record<string, string>; line: string }
  | { kind: 'NAK'; id: number; code: number; text: string; line: string };

/** The end of an action (`INF` or `ABS`), for HOME, MOVJ, MOVP, MOVL, JOG, WAIT, RUN, GET, PUT, SWAP, MAP, RETRACT, SENSE. */
export type FinalReply =
  | { kind: 'INF'; id: number; fields: Record<string, string>; line: string }
  | { kind: 'ABS'; id: number; code: number; text: string; line: string };

/** One real-time task's timing, from an `EVT TASK` line of the `TASKS` reply. */
export interface TaskTiming {
  name: string;
  priority: number;
  periodMs: number;
  cycles: number;
  overruns: number;
  missed: number;
  /** Measured period [µs]: average, minimum, maximum. */
  periodAvgUs: number;
  periodMinUs: number;
  periodMaxUs: number;
  /** Execution time [µs]: average, maximum. */
  execAvgUs: number;
  execMaxUs: number;
  /** Wake-up latency [µs]: average, 99th percentile, maximum. */
  latAvgUs: number;
  latP99Us: number;
  latMaxUs: number;
  /** Latency histogram: `[upperUs, count]` pairs, bin `u` holds latencies in [u/2, u) µs. */
  latHist: [number, number][];
}

export type Unsubscribe = () => void;

/** The connection every panel shares. */
export interface Bus {
  /** True while the WebSocket is open and `wrc ui` reports the controller connected. */
  connected(): boolean;
  onConnection(cb: (connected: boolean, detail: string) => void): Unsubscribe;
  /** The robot, once `ROBOT` has been answered (asked again after every reconnection). */
  robot(): RobotInfo | null;
  onRobot(cb: (robot: RobotInfo) => void): Unsubscribe;
  /** Every simulator datagram, decoded. */
  onSample(cb: (s: SimSample) => void): Unsubscribe;
  /** Every `EVT <name> …` line (name upper-case, rest after the name). */
  onEvent(cb: (name: string, body: string, line: string) => void): Unsubscribe;
  /**
   * Send one request (without an id: the bus adds one). Resolves with its first reply;
   * `final`, when the verb completes later (HOME, MOVJ, MOVP, MOVL, JOG, WAIT, RUN, GET, PUT,
   * SWAP, MAP, RETRACT, SENSE) and the first reply is an ACK, resolves with its INF or ABS.
   * Events that arrive between the request and its first reply (`EVT DIAG`, `EVT AXIS`, `EVT
   * TASK`, `EVT WAFER`, `EVT VAR`, `EVT POINT`, `EVT RECOVERY`) are collected in `events`
   * (lines without `EVT `).
   */
  request(line: string): Promise<{ first: FirstReply; final: Promise<FinalReply> | null; events: string[] }>;
  /** Send raw lines (UPLOAD and its text): the reply to the request among them is returned. */
  upload(name: string, text: string): Promise<{ first: FirstReply; events: string[] }>;
}
