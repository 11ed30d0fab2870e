// A program's named points as the Points panel keeps them: filled by `POINTS <program>`, kept in
// sync by `EVT POINT`, turned into the `POINT` requests that change them and into the TOML of
// the points file (crates/wrc-lang/src/points.rs) that the editor's compiler is given. Pure.

import type { PointEvent, PointValue } from './program-events';

/** A point's name: 1-32 letters, digits or `_`, starting with a letter or `_` (keywords are
 * refused by the controller). */
export function pointNameOk(name: string): boolean {
  return /^[A-Za-z_][A-Za-z0-9_]{0,31}$/.test(name);
}

/** One named point. */
export interface NamedPoint {
  name: string;
  value: PointValue;
}

/** A number as TOML writes a float (`250.0`, `-0.5`, `1e-7`). */
function tomlNumber(v: number): string {
  if (!Number.isFinite(v)) throw new Error('a point holds finite numbers only');
  const s = String(v);
  return /[.eE]/.test(s) ? s : `${s}.0`;
}

/** A number as the protocol writes it (no exponent, at most 6 decimals). */
function protocolNumber(v: number): string {
  if (!Number.isFinite(v)) throw new Error('a point holds finite numbers only');
  const s = v.toFixed(6).replace(/0+$/, '').replace(/\.$/, '');
  return s === '-0' ? '0' : s;
}

/** The points of one program, by name (names compared ignoring case, as the language does). */
export class PointStore {
  private points = new Map<string, NamedPoint>();
  /** The program whose points these are ('' before the first). */
  program = '';

  /** The reply to `POINTS <program>`: these are all its points. */
  replaceAll(program: string, events: readonly PointEvent[]): void {
    this.program = program;
    this.points.clear();
    for (const e of events) this.apply(e);
  }

  /** An `EVT POINT` (or a `POINT` reply); true when it was for this program. */
  apply(e: PointEvent): boolean {
    if (e.program !== this.program) return false;
    const key = e.name.toUpperCase();
    if (e.value === null) this.points.delete(key);
    else this.points.set(key, { name: this.points.get(key)?.name ?? e.name, value: e.value });
    return true;
  }

  /** Switch to another program: no points until its `POINTS` reply. */
  clear(program: string): void {
    this.program = program;
    this.points.clear();
  }

  get(name: string): NamedPoint | undefined {
    return this.points.get(name.toUpperCase());
  }

  /** The points, sorted by name. */
  list(): NamedPoint[] {
    return [...this.points.values()].sort((a, b) => (a.name.toUpperCase() < b.name.toUpperCase() ? -1 : 1));
  }

  /** The points file: `[points]` and one inline table a point ('' when there are none). */
  toToml(): string {
    const list = this.list();
    if (list.length === 0) return '';
    const lines = ['[points]'];
    for (const p of list) {
      const v = p.value;
      if (v.kind === 'pose') {
        lines.push(`${p.name} = { x = ${tomlNumber(v.x)}, y = ${tomlNumber(v.y)}, z = ${tomlNumber(v.z)}, yaw = ${tomlNumber(v.yaw)} }`);
      } else {
        lines.push(`${p.name} = { joints = [${v.joints.map(tomlNumber).join(', ')}] }`);
      }
    }
    return `${lines.join('\n')}\n`;
  }
}

/** `POINT <program> <name> <x> <y> <z> <yaw>` or `… JOINTS <j1> …`: store a value. */
export function pointSetRequest(program: string, name: string, value: PointValue): string {
  if (value.kind === 'pose') {
    return `POINT ${program} ${name} ${[value.x, value.y, value.z, value.yaw].map(protocolNumber).join(' ')}`;
  }
  return `POINT ${program} ${name} JOINTS ${value.joints.map(protocolNumber).join(' ')}`;
}

/** `POINT <program> <name> HERE`: store where the robot is (a joints point stays joints). */
export function pointHereRequest(program: string, name: string): string {
  return `POINT ${program} ${name} HERE`;
}

/** `POINT <program> <name> DELETE`. */
export function pointDeleteRequest(program: string, name: string): string {
  return `POINT ${program} ${name} DELETE`;
}

/** Numbers typed into the panel: each a finite number, or an error naming the field. */
export function readNumbers(fields: readonly { label: string; text: string }[]): number[] | string {
  const out: number[] = [];
  for (const f of fields) {
    const t = f.text.trim();
    const v = t === '' ? NaN : Number(t);
    if (!Number.isFinite(v)) return `${f.label} must be a number`;
    out.push(v);
  }
  return out;
}
