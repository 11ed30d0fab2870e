// The header, on every tab: the robot, the connection, the state, homed, the running program
// (running, paused at a breakpoint, waiting for the operator), the error, a program's alarm,
// the recovery banner, who holds control (this page, another tab of this browser, another
// client), the control lock, RESET and the E-STOP. It fits 1280 px: texts are cut with an
// ellipsis (their whole text in the tooltip), the buttons and the E-STOP never shrink.

import { h, setAttr, setText } from '../dom';
import type { Commander } from '../protocol/commander';
import type { ControllerModel } from '../protocol/controller-model';
import type { NoticeBoard } from '../protocol/notices';
import { sendReset } from '../protocol/notice-feed';
import { STOP_CODES } from '../protocol/notices';
import { programBadge, type ProgramTracker } from '../protocol/program-tracker';
import { ownerText, type TabPeers } from '../protocol/tabs';
import { mountEstop } from './estop';

export interface HeaderDeps {
  model: ControllerModel;
  cmd: Commander;
  board: NoticeBoard;
  program: ProgramTracker;
  tabs: TabPeers;
  /** The alarm banner and the recovery banner, placed after the error. */
  banners: HTMLElement[];
}

export function mountHeader(d: HeaderDeps): HTMLElement {
  const { model, cmd, program, tabs } = d;
  const robotName = h('span', { class: 'robot-name', 'data-testid': 'robot-name' }, '');
  const conn = h('span', { class: 'conn', 'data-testid': 'connection', 'data-connected': '0' }, 'connecting…');
  const state = h('span', { class: 'state-badge big', 'data-testid': 'state', 'data-state': 'OFFLINE' }, 'OFFLINE');
  const homed = h('span', { class: 'homed', 'data-testid': 'homed', 'data-homed': '0' }, '');
  const prog = h('span', { class: 'program-badge', 'data-testid': 'header-program', 'data-state': 'none', hidden: true });
  const err = h('span', { class: 'header-error', 'data-testid': 'header-error', 'data-kind': 'alarm' }, '');
  const owner = h('span', { class: 'owner', 'data-testid': 'lock-owner' }, 'nobody');
  const lockBtn = h('button', {
    class: 'btn lock',
    'data-testid': 'take-control',
    onclick: () => void cmd.send(model.holdsControl() ? 'RELEASE' : 'CONTROL'),
  }, 'Take control');
  const resetBtn = h('button', {
    class: 'btn reset',
    'data-testid': 'reset',
    title: 'RESET: clear ERROR / ESTOP once the cause is gone (answered once the arm stands still)',
    onclick: () => void sendReset(cmd, d.board),
  }, 'Reset');
  const estop = mountEstop(cmd);

  const header = h(
    'header',
    { class: 'app-header' },
    h('div', { class: 'brand' }, h('span', { class: 'logo' }, 'wrc'), robotName),
    conn,
    state,
    homed,
    prog,
    err,
    ...d.banners,
    h('span', { class: 'spacer' }),
    h('span', { class: 'lock-label' }, 'Control: ', owner),
    lockBtn,
    resetBtn,
    estop.el,
  );

  function drawProgram(): void {
    const text = programBadge(program.v);
    prog.hidden = text === '';
    setText(prog, text);
    setAttr(prog, 'title', text);
    setAttr(prog, 'data-state', program.v.state);
  }
  program.onChange(() => drawProgram());
  drawProgram();

  let lastMine: string | null = null;
  function drawOwner(): void {
    const v = model.v;
    const mine = model.holdsControl();
    const text = ownerText(v.owner, v.me, (s) => tabs.isPeer(s));
    setText(owner, text);
    setAttr(owner, 'title', text);
    setAttr(owner, 'data-owner', v.owner);
    setAttr(owner, 'data-mine', mine ? '1' : '0');
    setAttr(owner, 'data-peer', !mine && tabs.isPeer(v.owner) ? '1' : '0');
    const me = mine ? v.me : null;
    if (me !== lastMine) {
      lastMine = me;
      tabs.announce(me);
    }
  }
  tabs.onChange(() => drawOwner());

  model.onChange((v) => {
    setText(conn, v.connected ? 'connected' : v.connDetail || 'disconnected');
    setAttr(conn, 'title', v.connDetail);
    setAttr(conn, 'data-connected', v.connected ? '1' : '0');
    const s = v.connected ? (v.state ?? '…') : 'OFFLINE';
    setText(state, s);
    setAttr(state, 'data-state', s);
    setText(homed, v.homed === null || !v.connected ? '' : v.homed ? 'homed' : 'not homed');
    setAttr(homed, 'data-homed', v.homed ? '1' : '0');
    setText(err, v.errText);
    setAttr(err, 'title', v.errText);
    // A stop someone asked for is not a fault: amber, not red.
    setAttr(err, 'data-kind', STOP_CODES.has(v.err) ? 'stop' : 'alarm');
    err.hidden = v.errText === '';
    if (v.robot) setText(robotName, v.robot.name);
    drawOwner();
    const mine = model.holdsControl();
    setText(lockBtn, mine ? 'Release control' : 'Take control');
    lockBtn.disabled = !v.connected || (v.owner !== 'none' && !mine);
    setAttr(lockBtn, 'title', lockBtn.disabled && v.connected ? `control is held by ${owner.textContent}` : mine ? 'RELEASE: give control back' : 'CONTROL: take control (others may then only STOP, ESTOP and ask)');
    resetBtn.disabled = !v.connected;
    estop.update(v);
    document.title = `wrc — ${v.robot?.name ?? 'robot'} — ${s}`;
  });
  return header;
}
