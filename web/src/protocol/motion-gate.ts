// Why the Control panel's Go, Home, jog and output switches are disabled now, as a sentence
// that says what to do first ('' when they may be pressed). The controller decides (its
// admission rules: crates/wrc-controller/src/command_interpreter/admission.rs) and checks
// every request again; these rules, in the same order, only keep the operator from pressing
// what it would refuse and say why. Pure, unit-tested.

import type { RobotState } from './bus';
import type { RunState } from '../editor/debug-state';

/** What the gate looks at. */
export interface GateInput {
  connected: boolean;
  state: RobotState | null;
  homed: boolean | null;
  /** The source holding control (`none`: nobody). */
  owner: string;
  /** This page's source, once known. */
  me: string | null;
  /** How to name the holder to the operator (`another tab of this browser (gui0)`). */
  ownerText?: string;
  /** The program's state (`none` when none runs) and name. */
  program: RunState;
  programName?: string | null;
  /** A transfer or mapping in progress (the wafer map's `pending`), as `GET LP1.3 W3`; null: none. */
  transfer?: string | null;
}

/** `home`: HOME (allowed before homing); `move`: MOVJ, MOVP, MOVL; `jog`: JOG. */
export type MotionKind = 'home' | 'move' | 'jog';

function controlRefusal(g: GateInput): string {
  if (!g.connected) return 'not connected to the controller';
  if (g.owner !== 'none' && g.owner !== g.me) {
    return `control is held by ${g.ownerText ?? g.owner}: take control once it is released`;
  }
  return '';
}

/**
 * Why a running program refuses motions and transfers from the page ('' when none runs): the
 * controller answers them 127 while it runs, is paused or waits.
 */
export function programRefusal(program: RunState, programName?: string | null): string {
  const name = programName ?? 'a program';
  switch (program) {
    case 'running':
    case 'stepping':
      return `${name} is running: ABORT it (Editor) first`;
    case 'paused':
      return `${name} is paused: CONTINUE or ABORT it (Editor) first`;
    case 'waiting':
      return `${name} waits for the operator: answer it (CONTINUE) or ABORT it first`;
    case 'none':
      return '';
  }
}

/** Why a motion of `kind` would be refused now ('' when the controller would take it). */
export function motionRefusal(kind: MotionKind, g: GateInput): string {
  const control = controlRefusal(g);
  if (control) return control;
  if (g.transfer) return `a transfer or mapping is in progress (${g.transfer}): wait for its end or STOP`;
  const program = programRefusal(g.program, g.programName);
  if (program) return program;
  switch (g.state) {
    case 'ERROR':
      return 'the robot is in ERROR: RESET first';
    case 'ESTOP':
      return 'the robot is in ESTOP: release the E-stop and RESET first';
    case 'STOPPING':
      return 'the robot is stopping: wait until it stands still';
    case 'HELD':
      return 'a motion is held: RESUME it, or STOP to abandon it';
    case 'IDLE':
    case 'MOVING':
    case null:
      break;
  }
  if (kind !== 'home' && g.homed === false) return 'the robot is not homed: HOME first';
  return '';
}

/** Why an output may not be switched now ('' when it may): it needs control, like a motion. */
export function outputRefusal(g: GateInput): string {
  return controlRefusal(g);
}
