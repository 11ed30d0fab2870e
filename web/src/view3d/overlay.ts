// The text in the 3D view's corner: the robot, the link, the state, the TCP, the stream's rate
// and lost datagrams, or, while a trace is shown, which trace and where in it.

import type { RobotInfo, RobotState, SimSample } from '../protocol/bus';
import { h } from '../dom';
import { armPose, forwardTcp, type ArmAxes } from './sim-kinematics';

/** What the overlay shows. */
export interface OverlayView {
  /** The robot drawn, or else the one the bus knows. */
  robot: RobotInfo | null;
  /** The drawing's robot and axes (null before a robot is drawn). */
  drawn: { robot: RobotInfo; axes: ArmAxes } | null;
  connected: boolean;
  /** The live sample drawn (null before one was, and while a recorded frame is shown). */
  live: SimSample | null;
  /** The recorded frame shown instead of the live robot, if any. */
  recorded: { label: string; state: RobotState | null; positions: readonly number[] } | null;
  /** Datagram rate [Hz] (0: no stream). */
  rateHz: number;
  /** Datagrams lost, and in how many gaps. */
  lost: number;
  gaps: number;
}

function line(parent: HTMLElement, key: string, value: string, cls = ''): void {
  parent.append(h('div', {}, h('span', { class: 'sim-k' }, key.padEnd(8)), h('span', { class: cls || undefined }, value)));
}

const fmt = (x: number, d = 1): string => (Number.isFinite(x) ? x.toFixed(d) : '—');

/** Replace the contents of `el` with the lines for `v`. */
export function drawOverlay(el: HTMLElement, v: OverlayView): void {
  el.replaceChildren();
  line(el, 'robot', v.robot ? v.robot.name : '—');
  if (!v.connected) line(el, 'link', 'disconnected', 'sim-warn');
  const s = v.live;
  const recorded = v.recorded;
  if (recorded !== null) {
    line(el, 'trace', recorded.label, 'sim-warn');
    const st = recorded.state;
    line(el, 'state', st ?? '—', st ? `sim-state sim-state-${st}` : '');
    if (v.drawn) {
      const tcp = forwardTcp(v.drawn.robot, armPose(v.drawn.axes, recorded.positions));
      line(el, 'TCP', `${fmt(tcp.x)} ${fmt(tcp.y)} ${fmt(tcp.z)} mm`);
      line(el, 'yaw', `${fmt(tcp.yaw, 2)}°`);
    }
  } else if (s) {
    line(el, 'state', s.state, `sim-state sim-state-${s.state}`);
    line(el, 'homed', s.homed ? 'yes' : 'no', s.homed ? '' : 'sim-warn');
    line(el, 'TCP', `${fmt(s.x)} ${fmt(s.y)} ${fmt(s.z)} mm`);
    line(el, 'yaw', `${fmt(s.yaw, 2)}°`);
    line(el, 'seq', String(s.seq));
  } else {
    line(el, 'state', '—');
  }
  const rate = v.rateHz;
  line(el, 'rate', rate > 0 ? `${rate.toFixed(0)} Hz` : 'no stream', rate > 0 ? '' : 'sim-warn');
  line(el, 'lost', `${v.lost} in ${v.gaps} gap${v.gaps === 1 ? '' : 's'}`, v.lost > 0 ? 'sim-warn' : '');
  if (s && v.drawn) {
    // The drawing follows ROBOT's geometry; say so when it disagrees with the stream's TCP.
    const tcp = forwardTcp(v.drawn.robot, armPose(v.drawn.axes, s.positions));
    const err = Math.hypot(tcp.x - s.x, tcp.y - s.y, tcp.z - s.z);
    if (err > 1) line(el, 'geometry', `off by ${err.toFixed(1)} mm`, 'sim-warn');
  }
}
