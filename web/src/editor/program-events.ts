// Parsing of the debugger's lines of the host protocol (docs/protocol.md): `EVT PROGRAM` with
// its detail, `EVT VAR`, `EVT POINT`, `EVT ALARM`, the `line=` of the status stream and the
// `breaks=` of a BREAK reply. Pure functions on strings, unit-tested; no DOM.

/** A place in a running program: a source file as events name it (the program's or a
 * library's name) and a line [1-based]. */
export interface SourceAt {
  file: string;
  line: number;
}

/** `EVT PROGRAM <name> <state> [<detail>]`, its detail read. */
export type ProgramEvent =
  | { name: string; state: 'RUNNING'; files: string[] | null; step: boolean }
  | { name: string; state: 'PAUSED'; at: SourceAt | null }
  | { name: string; state: 'WAITING'; at: SourceAt | null; text: string }
  | { name: string; state: 'ENDED' };

function words(s: string): string[] {
  return s.split(/[ \t]+/).filter((w) => w.length > 0);
}

/** `demo:12` or `cell_lib:30` (the last `:` splits: names have none). */
export function parseSourceAt(text: string | undefined): SourceAt | null {
  if (!text) return null;
  const m = /^([A-Za-z0-9_.-]+):(\d+)$/.exec(text.trim());
  if (!m) return null;
  return { file: m[1], line: Number(m[2]) };
}

/**
 * The body of `EVT PROGRAM`: `demo RUNNING files=demo,cell_lib`, `demo RUNNING step`,
 * `demo PAUSED demo:12`, `demo PAUSED`, `demo WAITING demo:7 Load the cassette`,
 * `demo ENDED`. Null for anything else.
 */
export function parseProgramDetail(body: string): ProgramEvent | null {
  const m = /^\s*(\S+)[ \t]+(\S+)[ \t]*(.*)$/.exec(body);
  if (!m) return null;
  const name = m[1];
  const state = m[2].toUpperCase();
  const detail = m[3].trim();
  switch (state) {
    case 'RUNNING': {
      const f = /(?:^|[ \t])files=(\S*)/.exec(detail);
      return {
        name,
        state,
        files: f ? f[1].split(',').filter((s) => s.length > 0) : null,
        step: words(detail).includes('step'),
      };
    }
    case 'PAUSED':
      return { name, state, at: parseSourceAt(words(detail)[0]) };
    case 'WAITING': {
      const w = /^(\S+)[ \t]*(.*)$/.exec(detail);
      const at = parseSourceAt(w?.[1]);
      // Without a position the whole detail is the operator's text.
      return { name, state, at, text: at ? (w?.[2] ?? '') : detail };
    }
    case 'ENDED':
      return { name, state };
    default:
      return null;
  }
}

/** One `EVT VAR` line: a variable's type and value, or that there is none of that name. */
export type VarValue =
  | { name: string; known: true; type: string; value: string }
  | { name: string; known: false; why: string };

/**
 * `EVT VAR <name> <type> <value>` (body after `VAR`): `COUNT number 3`, `P pose POSE(250, 0,
 * 10, 0)`, `S string "say ""hi"""`, `A number[3] 1,2,3`, or `X unknown` / `X unknown (why)`.
 */
export function parseVar(body: string): VarValue | null {
  const m = /^\s*(\S+)[ \t]+(\S+)[ \t]?(.*)$/.exec(body);
  if (!m) return null;
  if (m[2] === 'unknown') {
    const why = m[3].trim().replace(/^\((.*)\)$/, '$1');
    return { name: m[1], known: false, why };
  }
  return { name: m[1], known: true, type: m[2], value: m[3] };
}

/** A named point's value: a pose (x, y, z [mm], yaw [deg]) or joint positions. */
export type PointValue =
  | { kind: 'pose'; x: number; y: number; z: number; yaw: number }
  | { kind: 'joints'; joints: number[] };

/** One `EVT POINT` line: a point of a program set (`value`) or deleted (`null`). */
export interface PointEvent {
  program: string;
  name: string;
  value: PointValue | null;
}

/**
 * `EVT POINT <program> <name> pose <x> <y> <z> <yaw>`, `… joints <j1> …` or `… deleted`
 * (body after `POINT`; also the `ACK` of `POINT` after its id).
 */
export function parsePoint(body: string): PointEvent | null {
  const ws = words(body);
  if (ws.length < 3) return null;
  const [program, name, kind, ...rest] = ws;
  const nums = rest.map(Number);
  if (nums.some((n) => !Number.isFinite(n))) return null;
  switch (kind.toLowerCase()) {
    case 'deleted':
      return rest.length === 0 ? { program, name, value: null } : null;
    case 'pose':
      if (nums.length !== 4) return null;
      return { program, name, value: { kind: 'pose', x: nums[0], y: nums[1], z: nums[2], yaw: nums[3] } };
    case 'joints':
      if (nums.length < 1) return null;
      return { program, name, value: { kind: 'joints', joints: nums } };
    default:
      return null;
  }
}

/** `line=<file index>:<line>` at the end of an `EVT STATUS` body (a program runs), or null. */
export function statusLine(body: string): { file: number; line: number } | null {
  const m = /(?:^|[ \t])line=(\d+):(\d+)(?:[ \t]|$)/.exec(body);
  if (!m) return null;
  return { file: Number(m[1]), line: Number(m[2]) };
}

/** `breaks=12,cell_lib:30` (or `none`) of a BREAK reply: lines of the program and of others. */
export function parseBreaks(value: string | undefined): { lines: number[]; others: SourceAt[] } {
  const out = { lines: [] as number[], others: [] as SourceAt[] };
  if (!value || value === 'none') return out;
  for (const item of value.split(',')) {
    if (/^\d+$/.test(item)) out.lines.push(Number(item));
    else {
      const at = parseSourceAt(item);
      if (at) out.others.push(at);
    }
  }
  return out;
}

/** `EVT ALARM <code> <program> <file>:<line>: <text>`: a program's ALARM. */
export interface AlarmEvent {
  code: number;
  program: string;
  at: SourceAt | null;
  text: string;
}

/** The body of `EVT ALARM`; a body that does not read so keeps its words as the text. */
export function parseAlarm(body: string): AlarmEvent | null {
  const m = /^\s*(\d+)[ \t]+(\S+)[ \t]+([A-Za-z0-9_.-]+:\d+):[ \t]*(.*)$/.exec(body);
  if (m) return { code: Number(m[1]), program: m[2], at: parseSourceAt(m[3]), text: m[4] };
  const n = /^\s*(\d+)[ \t]*(.*)$/.exec(body);
  if (!n) return null;
  return { code: Number(n[1]), program: '', at: null, text: n[2] };
}
