// Types of trace-fixture.mjs (trace files built field by field, for the GUI's tests).

export const STATE_NAMES: string[];
/** The format version a file is written with unless told (2). */
export const FORMAT_VERSION: number;
/** The direction codes of a message record. */
export const DIRECTION_CODES: { request: 0; reply: 1; opened: 2; closed: 3 };

export interface FixtureMeta {
  wrcVersion?: string;
  reason?: string;
  clock?: 'monotonic' | 'virtual';
  periodNs?: number;
  axisNames?: string[];
  stateNames?: string[];
  configToml?: string;
  stationsToml?: string | null;
  wafersToml?: string | null;
  worldToml?: string | null;
  programs?: { name: string; text: string }[];
  startPulses?: number[];
  fromStart?: boolean;
  savedAtNs?: number;
}

export interface FixtureSample {
  tNs: number;
  commanded?: number[];
  actual?: number[];
  inputs?: number;
  outputs?: number;
  state?: number;
  errorCode?: number;
  fifoLevel?: number;
  latencyNs?: number;
  execNs?: number;
}

export interface FixtureMessage {
  tNs: number;
  /** A name, or a code written as it is (a bad one, for a test). */
  direction: 'request' | 'reply' | 'opened' | 'closed' | number;
  source?: number;
  client?: number;
  truncated?: boolean;
  /** Empty when absent (an opened or closed message). */
  line?: string;
}

export function crc32Bitwise(bytes: Uint8Array): number;
export function section(tag: string, body: Uint8Array, opts?: { length?: number; crc?: number }): Uint8Array;
export function metaBody(meta?: FixtureMeta): Uint8Array;
export function samplesBody(samples: FixtureSample[], axes: number, count?: number): Uint8Array;
export function messagesBody(messages: FixtureMessage[], count?: number): Uint8Array;
export function traceBytes(sections: Uint8Array[], opts?: { version?: number; magic?: string }): Uint8Array;
export function encodeTrace(spec?: {
  meta?: FixtureMeta;
  samples?: FixtureSample[];
  messages?: FixtureMessage[];
  version?: number;
}): Uint8Array;
