// The robot a trace recorded, for the 3D view: its geometry and axes from the configuration
// text the trace carries (its meta's `config_toml`: `[robot]`, `[motion]` and the `[[axis]]`
// tables of config/default.toml, and `[hand.blade_b]` of a dual-blade robot), and a sample's encoder pulses as joint positions:
// position = actual pulses / pulses_per_unit [deg | mm]. No DOM.

import { TomlError, parse } from 'smol-toml';
import type { AxisInfo, RobotInfo } from '../protocol/bus';
import type { TraceMeta, TraceSamples } from './trace';

type Table = Record<string, unknown>;

function isTable(v: unknown): v is Table {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

/** Why a configuration text does not give a robot to draw: one sentence. */
export class ConfigTextError extends Error {}

/**
 * Blade B's height above the hand [mm] from `[hand.blade_b]` z_offset_mm, or null. A missing
 * or unreadable value draws a single hand rather than refusing the trace: the drawing only
 * needs it for the second fork.
 */
function bladeBOffset(doc: Table): number | null {
  const hand = doc.hand;
  if (!isTable(hand) || !isTable(hand.blade_b)) return null;
  const z = hand.blade_b.z_offset_mm;
  return typeof z === 'number' && Number.isFinite(z) ? z : null;
}

/**
 * The robot of a configuration text (TOML, as `wrc up --config` reads it): `[robot]` name,
 * link1_mm, link2_mm, hand_mm; `[motion]` period_ms; one `[[axis]]` per axis with name, role,
 * unit, pulses_per_unit, min, max and home; `[hand.blade_b]` z_offset_mm (dual-blade only). Throws `ConfigTextError` when the text is not
 * TOML or lacks what the drawing needs (the links; each axis's name and pulses_per_unit).
 */
export function robotFromConfigToml(text: string): RobotInfo {
  let doc: Table;
  try {
    doc = parse(text);
  } catch (e) {
    if (e instanceof TomlError) {
      throw new ConfigTextError(`it is not TOML (line ${e.line}, column ${e.column}: ${e.message.split('\n')[0]})`);
    }
    throw new ConfigTextError(`it is not TOML (${String(e)})`);
  }
  const robot = doc.robot;
  if (!isTable(robot)) throw new ConfigTextError('it has no [robot] table');
  const num = (t: Table, key: string, where: string, fallback?: number): number => {
    const v = t[key];
    if (typeof v === 'number' && Number.isFinite(v)) return v;
    if (v === undefined && fallback !== undefined) return fallback;
    throw new ConfigTextError(`${where}.${key} is ${v === undefined ? 'missing' : 'not a number'}`);
  };
  const str = (t: Table, key: string, fallback: string): string => {
    const v = t[key];
    return typeof v === 'string' ? v : fallback;
  };
  const rawAxes = doc.axis;
  if (!Array.isArray(rawAxes) || rawAxes.length === 0) throw new ConfigTextError('it has no [[axis]] table');
  const axes: AxisInfo[] = rawAxes.map((a: unknown, i): AxisInfo => {
    const where = `axis[${i + 1}]`;
    if (!isTable(a)) throw new ConfigTextError(`${where} is not a table`);
    const name = a.name;
    if (typeof name !== 'string' || name === '') throw new ConfigTextError(`${where}.name is missing`);
    const ppu = num(a, 'pulses_per_unit', where);
    if (!(ppu > 0)) throw new ConfigTextError(`${where}.pulses_per_unit is ${ppu}; it is above 0`);
    return {
      index: i + 1,
      name,
      role: str(a, 'role', 'auxiliary'),
      unit: str(a, 'unit', 'deg'),
      ppu,
      min: num(a, 'min', where, 0),
      max: num(a, 'max', where, 0),
      home: num(a, 'home', where, 0),
    };
  });
  const motion = isTable(doc.motion) ? doc.motion : {};
  return {
    name: str(robot, 'name', 'robot'),
    link1: num(robot, 'link1_mm', 'robot'),
    link2: num(robot, 'link2_mm', 'robot'),
    hand: num(robot, 'hand_mm', 'robot', 0),
    bladeB: bladeBOffset(doc),
    periodMs: num(motion, 'period_ms', 'motion', 10),
    inputs: 32,
    outputs: 32,
    axes,
  };
}

/** The robot to draw a trace with, and which trace axis drives each of its axes. */
export interface TraceRobot {
  robot: RobotInfo;
  /**
   * For each of `robot.axes`, the index of the trace axis of the same name (null: the trace
   * did not record it; drawn at its home).
   */
  traceAxis: (number | null)[];
  /** '' when the robot is the trace's own; otherwise why the live robot is used instead. */
  note: string;
}

/**
 * The robot of `meta`'s configuration text or, when the trace carries none that can be read,
 * the live robot (`live`, from `ROBOT`), with the trace's axes matched to it by name. An
 * error sentence when neither gives a robot with one of the trace's axes.
 */
export function traceRobot(
  meta: Pick<TraceMeta, 'axisNames' | 'configToml'>,
  live: RobotInfo | null,
): { ok: true; value: TraceRobot } | { ok: false; reason: string } {
  let robot: RobotInfo;
  let note = '';
  try {
    robot = robotFromConfigToml(meta.configToml);
  } catch (e) {
    const why = e instanceof ConfigTextError ? e.message : String(e);
    const own = meta.configToml.trim() === '' ? 'the trace carries no configuration' : `the trace's configuration cannot be used: ${why}`;
    if (live === null) return { ok: false, reason: `${own}, and the live robot is not known` };
    robot = live;
    note = `${own}; drawn with the live robot's axes`;
  }
  const traceAxis = robot.axes.map((a) => {
    const i = meta.axisNames.indexOf(a.name);
    return i >= 0 ? i : null;
  });
  if (traceAxis.every((i) => i === null)) {
    return {
      ok: false,
      reason: `none of the trace's axes (${meta.axisNames.join(', ') || 'none'}) is an axis of robot ${robot.name} (${robot.axes.map((a) => a.name).join(', ')})`,
    };
  }
  return { ok: true, value: { robot, traceAxis, note } };
}

/** The robot's axis positions in sample `i` [deg | mm], in the robot's axis order. */
export function positionsAt(tr: TraceRobot, samples: TraceSamples, i: number): number[] {
  return tr.robot.axes.map((a, k) => {
    const ti = tr.traceAxis[k];
    return ti === null || ti === undefined ? a.home : samples.actualAt(i, ti) / a.ppu;
  });
}
