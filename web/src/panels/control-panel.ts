// The Control panel (the paper's Fig. 6): current position, destination (PTP / Straight /
// Joint) with Go, Home, Stop, Hold and Resume, jog, signals, control lock, and the command log
// that shows each request's ACK/NAK and INF/ABS. It draws the `ControllerModel` and sends
// through the `Commander` (protocol/); this module is only the DOM.
//
// Go, Home, the jog buttons and the outputs are disabled, with the reason beside them and in
// their tooltips, whenever the controller would refuse them (motion-gate.ts). The destination
// is filled from the robot (WHERE) after every connection, before Go may send it: Go never
// commands fields that were not read from the robot or typed.

import type { RobotInfo } from '../protocol/bus';
import type { Commander } from '../protocol/commander';
import { resumeRefusal, type ControllerModel } from '../protocol/controller-model';
import { motionRefusal, outputRefusal, type GateInput } from '../protocol/motion-gate';
import type { ProgramTracker } from '../protocol/program-tracker';
import { fmtNum } from '../protocol/protocol';
import { ownerText, type TabPeers } from '../protocol/tabs';
import { formatPending, type WaferStore } from '../cell/wafers';
import { h, setAttr, setText } from '../dom';
import { commandLogView } from './command-log';
import { signalsCard } from './signals-card';

/** Tooltip of the HOLD button. */
export const HOLD_TITLE = 'HOLD: brake on the path and keep the motion (RESUME continues it)';
/** Tooltip of the RESUME button (a reason is added while it is disabled). */
export const RESUME_TITLE = 'RESUME: continue the held motion on its path';

type Mode = 'ptp' | 'line' | 'joint';

export interface ControlPanel {
  resize(): void;
}

function numberInput(testid: string, label: string, unit: string): { wrap: HTMLElement; input: HTMLInputElement } {
  const input = h('input', {
    type: 'number',
    step: 'any',
    class: 'num',
    'data-testid': testid,
    'aria-label': label,
    value: '0',
  });
  const wrap = h('label', { class: 'field' }, h('span', { class: 'field-label' }, label), input, h('span', { class: 'unit' }, unit));
  return { wrap, input };
}

function section(title: string, ...children: (Node | null)[]): HTMLElement {
  return h('section', { class: 'card' }, h('h3', {}, title), ...children);
}

/** What the Control panel follows besides the controller. */
export interface ControlDeps {
  model: ControllerModel;
  cmd: Commander;
  /** The running program (motions are refused while one runs). */
  program: ProgramTracker;
  /** The other tabs of this browser (to name a holder of control). */
  peers: TabPeers;
  /** The wafer map (a transfer in progress; a guarded output's confirmation). */
  wafers: WaferStore;
}

/** Mount the Control panel in `el`; `cards` (e.g. the Trace card) go above the command log. */
export function mountControl(el: HTMLElement, deps: ControlDeps, cards: readonly HTMLElement[] = []): ControlPanel {
  const { model, cmd, program, peers, wafers } = deps;
  el.classList.add('control-panel');
  el.replaceChildren();

  // ---- Current ----
  const curState = h('span', { class: 'state-badge', 'data-testid': 'current-state' }, '—');
  const curHomed = h('span', { 'data-testid': 'current-homed' }, '—');
  const curSpeed = h('span', { 'data-testid': 'current-speed' }, '—');
  const curErr = h('div', { class: 'err-text', 'data-testid': 'current-error' });
  const axisBody = h('tbody');
  const pose: Record<'x' | 'y' | 'z' | 'yaw', HTMLElement> = {
    x: h('td', { class: 'val', 'data-testid': 'current-x' }, '—'),
    y: h('td', { class: 'val', 'data-testid': 'current-y' }, '—'),
    z: h('td', { class: 'val', 'data-testid': 'current-z' }, '—'),
    yaw: h('td', { class: 'val', 'data-testid': 'current-yaw' }, '—'),
  };
  const poseTable = h(
    'table',
    { class: 'vals pose' },
    h('tbody', {},
      h('tr', {}, h('th', {}, 'X'), pose.x, h('td', { class: 'unit' }, 'mm'), h('th', {}, 'Y'), pose.y, h('td', { class: 'unit' }, 'mm')),
      h('tr', {}, h('th', {}, 'Z'), pose.z, h('td', { class: 'unit' }, 'mm'), h('th', {}, 'Yaw'), pose.yaw, h('td', { class: 'unit' }, 'deg')),
    ),
  );
  const axisTable = h(
    'table',
    { class: 'vals axes' },
    h('thead', {}, h('tr', {}, h('th', {}, 'Axis'), h('th', { class: 'r' }, 'Position'), h('th', {}, ''), h('th', { class: 'r' }, 'Pulses'))),
    axisBody,
  );
  const current = section(
    'Current',
    h('div', { class: 'status-row' },
      h('span', {}, 'State ', curState),
      h('span', {}, 'Homed ', curHomed),
      h('span', {}, 'Speed ', curSpeed),
    ),
    axisTable,
    poseTable,
    curErr,
  );

  // ---- Destination ----
  let mode: Mode = 'ptp';
  const modeBtns: Record<Mode, HTMLButtonElement> = {
    ptp: h('button', { class: 'seg', 'data-testid': 'mode-ptp', onclick: () => setMode('ptp') }, 'PTP'),
    line: h('button', { class: 'seg', 'data-testid': 'mode-line', onclick: () => setMode('line') }, 'Straight'),
    joint: h('button', { class: 'seg', 'data-testid': 'mode-joint', onclick: () => setMode('joint') }, 'Joint'),
  };
  const dx = numberInput('dest-x', 'X', 'mm');
  const dy = numberInput('dest-y', 'Y', 'mm');
  const dz = numberInput('dest-z', 'Z', 'mm');
  const dyaw = numberInput('dest-yaw', 'Yaw', 'deg');
  const posture = h(
    'select',
    { 'data-testid': 'dest-posture', 'aria-label': 'Elbow posture' },
    h('option', { value: '' }, 'keep posture'),
    h('option', { value: 'L' }, 'L (left elbow)'),
    h('option', { value: 'R' }, 'R (right elbow)'),
  );
  const postureWrap = h('label', { class: 'field' }, h('span', { class: 'field-label' }, 'Posture'), posture);
  const poseFields = h('div', { class: 'fields' }, dx.wrap, dy.wrap, dz.wrap, dyaw.wrap, postureWrap);
  const jointFields = h('div', { class: 'fields' });
  let jointInputs: HTMLInputElement[] = [];
  const destError = h('div', { class: 'err-text', 'data-testid': 'dest-error' });
  /** Why Go, Home and jog are disabled (the gate's sentence), under the buttons. */
  const motionWhy = h('div', { class: 'hint motion-why', 'data-testid': 'motion-why' });

  const goBtn = h('button', { class: 'btn primary', 'data-testid': 'go', onclick: () => void go() }, 'Go');
  const homeBtn = h('button', { class: 'btn', 'data-testid': 'home', onclick: () => void cmd.send('HOME') }, 'Home');
  const stopBtn = h('button', { class: 'btn warn', 'data-testid': 'stop', onclick: () => void cmd.send('STOP') }, 'Stop');
  const holdBtn = h('button', { class: 'btn hold', 'data-testid': 'hold', title: HOLD_TITLE, onclick: () => void cmd.send('HOLD') }, 'Hold');
  const resumeBtn = h(
    'button',
    { class: 'btn resume', 'data-testid': 'resume', title: RESUME_TITLE, disabled: true, onclick: () => void cmd.send('RESUME') },
    'Resume',
  );
  const copyBtn = h('button', { class: 'btn small', 'data-testid': 'dest-copy', onclick: () => copyCurrent(), title: 'Fill the destination from the current position' }, 'Copy current');

  const speed = h('input', { type: 'range', min: '1', max: '100', step: '1', value: '100', 'data-testid': 'speed-slider', 'aria-label': 'Speed override' });
  const speedVal = h('span', { class: 'speed-val', 'data-testid': 'speed-value' }, '100 %');
  let draggingSpeed = false;
  speed.addEventListener('pointerdown', () => (draggingSpeed = true));
  speed.addEventListener('pointerup', () => (draggingSpeed = false));
  speed.addEventListener('input', () => setText(speedVal, `${speed.value} %`));
  speed.addEventListener('change', () => {
    draggingSpeed = false;
    void cmd.send(`SPEED ${speed.value}`);
  });

  const destination = section(
    'Destination',
    h('div', { class: 'seg-group' }, modeBtns.ptp, modeBtns.line, modeBtns.joint, copyBtn),
    // Both sets of fields in one place, the other one invisible: the buttons below stay put.
    h('div', { class: 'dest-fields' }, poseFields, jointFields),
    destError,
    h('div', { class: 'btn-row' }, goBtn, homeBtn, stopBtn, holdBtn, resumeBtn),
    motionWhy,
    h('div', { class: 'speed-row' }, h('span', { class: 'field-label' }, 'Speed'), speed, speedVal),
  );

  function setMode(m: Mode): void {
    mode = m;
    for (const [k, b] of Object.entries(modeBtns)) b.classList.toggle('active', k === m);
    poseFields.style.visibility = m === 'joint' ? 'hidden' : '';
    jointFields.style.visibility = m === 'joint' ? '' : 'hidden';
    // Kept in its place (invisible) for a straight line: the buttons below never jump.
    postureWrap.style.visibility = m === 'ptp' ? '' : 'hidden';
    setAttr(destination, 'data-mode', m);
  }
  setMode('ptp');

  function readNum(input: HTMLInputElement, what: string): string {
    const raw = input.value.trim();
    const n = Number(raw);
    if (raw === '' || !Number.isFinite(n)) throw new Error(`${what} is not a number`);
    return fmtNum(n);
  }

  async function go(): Promise<void> {
    setText(destError, '');
    const notRead = unfilled();
    if (notRead) {
      setText(destError, notRead);
      return;
    }
    let line: string;
    try {
      if (mode === 'joint') {
        const axes = model.v.robot?.axes ?? [];
        if (jointInputs.length === 0) throw new Error('the robot is not known yet');
        line = `MOVJ ${jointInputs.map((inp, i) => readNum(inp, axes[i]?.name ?? `axis ${i + 1}`)).join(' ')}`;
      } else {
        const xyz = [readNum(dx.input, 'X'), readNum(dy.input, 'Y'), readNum(dz.input, 'Z'), readNum(dyaw.input, 'Yaw')].join(' ');
        line = mode === 'ptp' ? `MOVP ${xyz}${posture.value ? ` ${posture.value}` : ''}` : `MOVL ${xyz}`;
      }
    } catch (e) {
      setText(destError, e instanceof Error ? e.message : String(e));
      return;
    }
    await cmd.send(line);
  }

  function copyCurrent(): void {
    const v = model.v;
    if (v.x !== null) dx.input.value = fmtNum(v.x);
    if (v.y !== null) dy.input.value = fmtNum(v.y);
    if (v.z !== null) dz.input.value = fmtNum(v.z);
    if (v.yaw !== null) dyaw.input.value = fmtNum(v.yaw);
    jointInputs.forEach((inp, i) => {
      const p = v.positions[i];
      if (p !== undefined) inp.value = fmtNum(p);
    });
  }

  // ---- Jog ----
  const jogStep = h(
    'select',
    { 'data-testid': 'jog-step', 'aria-label': 'Jog step [pulses]' },
    h('option', { value: '100' }, '100 pulses'),
    h('option', { value: '1000', selected: true }, '1000 pulses'),
    h('option', { value: '10000' }, '10000 pulses'),
  );
  const jogRows = h('div', { class: 'jog-rows' });
  const jog = section('Jog', h('div', { class: 'jog-head' }, h('span', { class: 'field-label' }, 'Step'), jogStep), jogRows);

  // ---- Signals ----
  const signals = signalsCard(cmd, () => {
    const st = wafers.state();
    return st.available === true ? st.map : null;
  });

  // ---- Control lock and log ----
  const ownerEl = h('span', { class: 'owner', 'data-testid': 'control-owner' }, 'none');
  const lockHint = h('div', { class: 'hint', 'data-testid': 'control-hint' });
  const raw = h('input', {
    type: 'text',
    class: 'raw',
    'data-testid': 'raw-command',
    placeholder: 'request, e.g. WHERE',
    spellcheck: 'false',
    autocomplete: 'off',
  });
  raw.addEventListener('keydown', (ev) => {
    if (ev.key !== 'Enter') return;
    const line = raw.value.trim();
    if (!line) return;
    if (/^\s*UPLOAD\b/i.test(line)) {
      cmd.log.add('nak', 'UPLOAD spans lines: use the Editor tab');
      return;
    }
    raw.value = '';
    void cmd.send(line);
  });
  const logCard = section(
    'Commands',
    h('div', { class: 'status-row' }, h('span', {}, 'Control: ', ownerEl)),
    lockHint,
    commandLogView(cmd.log),
    raw,
  );

  el.append(current, destination, jog, signals.el, ...cards, logCard);

  // ---- robot-dependent parts ----
  let axisCells: { pos: HTMLElement; pulses: HTMLElement }[] = [];
  let builtFor: RobotInfo | null = null;

  function buildRobot(r: RobotInfo): void {
    builtFor = r;
    axisBody.replaceChildren();
    axisCells = [];
    jointFields.replaceChildren();
    jointInputs = [];
    jogRows.replaceChildren();
    for (const a of r.axes) {
      const pos = h('td', { class: 'val', 'data-testid': `current-axis-${a.index}` }, '—');
      const pulses = h('td', { class: 'val', 'data-testid': `current-pulses-${a.index}` }, '—');
      axisBody.append(h('tr', {}, h('th', {}, a.name), pos, h('td', { class: 'unit' }, a.unit), pulses));
      axisCells.push({ pos, pulses });

      const f = numberInput(`dest-j${a.index}`, a.name, a.unit);
      f.input.title = `${a.min} to ${a.max} ${a.unit}`;
      jointInputs.push(f.input);
      jointFields.append(f.wrap);

      const jogBy = (sign: number) => () => void cmd.send(`JOG ${a.index} ${sign * Number(jogStep.value)}`);
      jogRows.append(
        h(
          'div',
          { class: 'jog-row' },
          h('span', { class: 'jog-name' }, `${a.name}`),
          h('button', { class: 'btn jog', 'data-testid': `jog-minus-${a.index}`, onclick: jogBy(-1), 'data-label': `JOG ${a.name} −` }, '−'),
          h('button', { class: 'btn jog', 'data-testid': `jog-plus-${a.index}`, onclick: jogBy(1), 'data-label': `JOG ${a.name} +` }, '+'),
          h('span', { class: 'unit' }, `${a.unit}, ${a.ppu} pulse/${a.unit}`),
        ),
      );
    }
    signals.build(r);
    // The new fields hold nothing read from the robot yet.
    filledEpoch = -1;
  }

  // The destination is filled from the robot after every connection (and after the robot is
  // built anew), until the operator types in it.
  let filledEpoch = -1;
  let touchedEpoch = -1;
  destination.addEventListener('input', (ev) => {
    if ((ev.target as HTMLElement).closest('.fields')) touchedEpoch = model.v.epoch;
  });

  /** Why Go would send fields that were never read from the robot ('' when they were). */
  function unfilled(): string {
    const v = model.v;
    if (filledEpoch === v.epoch || touchedEpoch === v.epoch) return '';
    return 'the destination is not yet read from the robot (WHERE)';
  }

  function render(): void {
    const v = model.v;
    if (v.robot && v.robot !== builtFor) buildRobot(v.robot);
    if (
      filledEpoch !== v.epoch &&
      touchedEpoch !== v.epoch &&
      v.robot &&
      builtFor === v.robot &&
      v.positionsEpoch === v.epoch &&
      v.x !== null &&
      v.positions.length > 0
    ) {
      filledEpoch = v.epoch;
      copyCurrent();
    }
    const state = v.connected ? (v.state ?? '—') : 'OFFLINE';
    setText(curState, state);
    setAttr(curState, 'data-state', state);
    setText(curHomed, v.homed === null ? '—' : v.homed ? 'yes' : 'no');
    setAttr(curHomed, 'data-homed', v.homed ? '1' : '0');
    setText(curSpeed, v.speed === null ? '—' : `${v.speed} %`);
    setText(curErr, v.errText);
    if (v.speed !== null && !draggingSpeed) {
      speed.value = String(v.speed);
      setText(speedVal, `${v.speed} %`);
    }
    for (const k of ['x', 'y', 'z', 'yaw'] as const) {
      const val = v[k];
      setText(pose[k], val === null ? '—' : val.toFixed(3));
    }
    axisCells.forEach((c, i) => {
      const p = v.positions[i];
      setText(c.pos, p === undefined ? '—' : p.toFixed(3));
      const q = v.pulses?.[i];
      setText(c.pulses, q === undefined ? '—' : String(q));
    });
    const st = wafers.state();
    const gate: GateInput = {
      connected: v.connected,
      state: v.state,
      homed: v.homed,
      owner: v.owner,
      me: v.me,
      ownerText: ownerText(v.owner, v.me, (x) => peers.isPeer(x)),
      program: program.v.state,
      programName: program.v.program,
      transfer: st.available === true && st.map.pending ? formatPending(st.map.pending) : null,
    };
    const whyMove = motionRefusal('move', gate) || unfilled();
    const whyHome = motionRefusal('home', gate);
    const whyJog = motionRefusal('jog', gate);
    const gated = (b: HTMLButtonElement, why: string, title: string): void => {
      b.disabled = why !== '';
      setAttr(b, 'title', why ? `${title} — ${why}` : title);
    };
    gated(goBtn, whyMove, 'Go: move to the destination');
    gated(homeBtn, whyHome, 'HOME: every axis to its home position');
    for (const b of Array.from(jogRows.querySelectorAll<HTMLButtonElement>('button'))) gated(b, whyJog, b.getAttribute('data-label') ?? 'JOG');
    setText(motionWhy, whyMove && whyMove === whyHome ? whyMove : whyMove ? `Go: ${whyMove}` : whyHome ? `Home: ${whyHome}` : '');
    signals.update(v, outputRefusal(gate));
    setText(ownerEl, gate.ownerText ?? v.owner);
    const may = model.mayCommand();
    // STOP and HOLD are accepted from every source, with or without control.
    stopBtn.disabled = !v.connected;
    holdBtn.disabled = !v.connected;
    const whyNotResume = resumeRefusal(v, may);
    resumeBtn.disabled = whyNotResume !== '';
    setAttr(resumeBtn, 'title', whyNotResume ? `${RESUME_TITLE} (${whyNotResume})` : RESUME_TITLE);
    setText(
      lockHint,
      !v.connected
        ? `not connected: ${v.connDetail}`
        : may
          ? ''
          : `control is held by ${gate.ownerText}; motions are refused until it is released`,
    );
  }

  model.onChange(() => render());
  program.onChange((_v, stateChanged) => {
    if (stateChanged) render();
  });
  wafers.onChange(() => render());
  peers.onChange(() => render());

  return { resize: () => undefined };
}
