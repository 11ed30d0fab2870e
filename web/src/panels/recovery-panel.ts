// The recovery panel: after a power loss interrupted a GET, PUT or SWAP, what happened (the
// journaled step), where the hand is and whether it may be inside a station, which wafers and
// slots are uncertain, and the next safe actions — Take control and Reset when they are needed
// first, Retract or Home, Sense per blade, Map per station with uncertain slots, or Confirm
// what the operator sees — each behind a dialog that says what will happen (for a CONFIRM,
// what the wafer map will record) and that sends nothing once the plan no longer allows its
// request (another source stopped the robot or took control meanwhile). A banner in the
// header (beside the alarm banner) says recovery is needed and opens the panel from any tab;
// both stay until nothing is uncertain, the hand is outside and alarm 216 is reset.
//
// The decisions (which steps are offered, which may be pressed and why not, what each dialog
// says) are plain functions of the report and the controller's state, unit-tested without a
// DOM; `mountRecovery` only draws them. Requests go through the Commander, so they and their
// replies appear in the command log too; the panel shows the last one's reply itself.

import type { FinalReply, FirstReply, RobotState } from '../protocol/bus';
import type { Commander } from '../protocol/commander';
import type { ControllerModel } from '../protocol/controller-model';
import { fmtNum } from '../protocol/protocol';
import { h, setAttr, setText } from '../dom';
import { frameThrottle } from '../frame-throttle';
import { showLayer } from './layer';
import type { StationInfo, StationsHandle } from '../cell/stations';
import type { Blade, WaferStore } from '../cell/wafers';
import {
  placeText,
  placeWords,
  recoveryNeeded,
  samePlace,
  uncertainWafers,
  type RecoveryPlace,
  type RecoveryReport,
  type RecoveryStore,
  type UncertainPlace,
} from '../cell/recovery';
import './recovery-panel.css';

/**
 * The speed of a retract out of a station [%] (the controller's `RETRACT_SPEED_PCT`): the
 * station's own speed, at most this. RECOVERY does not say it; the dialogs do.
 */
export const RETRACT_SPEED_PCT = 20;

/** The alarm a start-up raises when anything is uncertain or the hand may be inside a station. */
export const ALARM_INTERRUPTED = 216;

/** What the plan looks at. */
export interface RecoveryInput {
  report: RecoveryReport;
  connected: boolean;
  state: RobotState | null;
  homed: boolean | null;
  /** The source holding control (`none`: nobody). */
  owner: string;
  /** This page holds control. */
  holdsControl: boolean;
  /** The controller's error code (`err=`; 0: none). */
  err: number;
  /** A request this panel sent that has not ended yet (`SENSE`), or null. */
  running: string | null;
  /** The stations (their speed for the dialogs; may be empty before `STN` is answered). */
  stations: readonly Pick<StationInfo, 'name' | 'speed' | 'slots'>[];
  /** A blade holds a wafer, certain or not (a HOME that retracts then goes home slowly). */
  bladeLoaded?: boolean;
  /** The operator's speed override [%] (`speed=`; null or absent: 100): every motion is at most this. */
  override?: number | null;
}

/** One step the panel offers (a button), in the operator's order. */
export interface RecoveryStep {
  /** `control`, `reset`, `retract`, `home`, `sense-A`, `sense-B`, `map-<station>`. */
  id: string;
  /** The button's text. */
  label: string;
  /** The request it sends. */
  request: string;
  enabled: boolean;
  /** Why it is disabled ('' when enabled). */
  why: string;
  /** What the confirmation dialog says will happen; null: sent at once (control, reset). */
  confirm: string | null;
}

/** One thing an operator may confirm (`CONFIRM …`). */
export interface ConfirmChoice {
  /** `at-LP2.1`, `empty-hand`, `gone-W1`. */
  id: string;
  /** `W1 is in LP2 slot 1`. */
  label: string;
  /** `CONFIRM W1 LP2 1`. */
  request: string;
  /** What the confirmation dialog says will happen. */
  confirm: string;
}

export interface RecoveryPlan {
  /** Whether the banner and the panel are shown: recovery is needed, or alarm 216 is not reset. */
  shown: boolean;
  /** Nothing is uncertain and the hand is outside (only alarm 216 may remain). */
  settled: boolean;
  steps: RecoveryStep[];
  /** The id of the step to take next (the first one), or null when there is none. */
  next: string | null;
  confirms: ConfirmChoice[];
  /** Whether CONFIRM may be sent now, and why not. */
  confirmEnabled: boolean;
  confirmWhy: string;
  /** The banner's text. */
  summary: string;
}

/** `LP2 slot 1` → `LP2 1`; `the hand` → `HAND`; blade B → `HAND B` (CONFIRM's words). */
function confirmPlace(p: RecoveryPlace): string {
  if (p.kind === 'slot') return `${p.station} ${p.slot}`;
  return p.blade === 'B' ? 'HAND B' : 'HAND';
}

/** `a, b or c`. */
function orList(items: readonly string[]): string {
  if (items.length <= 1) return items.join('');
  return `${items.slice(0, -1).join(', ')} or ${items[items.length - 1]}`;
}

/** `a, b and c`. */
function andList(items: readonly string[]): string {
  if (items.length <= 1) return items.join('');
  return `${items.slice(0, -1).join(', ')} and ${items[items.length - 1]}`;
}

/** The sentence an operator reads first: capital letter. */
function capital(s: string): string {
  return s.charAt(0).toUpperCase() + s.slice(1);
}

const plural = (n: number, one: string, many = `${one}s`): string => `${n} ${n === 1 ? one : many}`;

/** The uncertain places of `wafer` other than `place`. */
function otherPlaces(r: RecoveryReport, wafer: string, place: RecoveryPlace): UncertainPlace[] {
  return r.uncertain.filter((u) => u.wafer === wafer && !samePlace(u.place, place));
}

/** Every CONFIRM the report allows, with what each does. */
export function confirmChoices(r: RecoveryReport): ConfirmChoice[] {
  const out: ConfirmChoice[] = [];
  const logged = 'The controller logs it as the operator\u2019s word; nothing moves.';
  for (const u of r.uncertain) {
    const at = placeWords(u.place);
    const key = placeText(u.place);
    const others = otherPlaces(r, u.wafer, u.place).map((o) => placeWords(o.place));
    const isBlade = u.place.kind === 'blade';
    const atReq = `CONFIRM ${u.wafer} ${confirmPlace(u.place)}`;
    out.push({
      id: `at-${key}`,
      label: `${u.wafer} is ${isBlade ? 'on' : 'in'} ${at}`,
      request: atReq,
      confirm:
        `${atReq}: your word that ${u.wafer} is ${isBlade ? 'on' : 'in'} ${at}. The wafer map keeps it there, certain` +
        (others.length > 0 ? `, and ${andList(others)} ${others.length === 1 ? 'becomes' : 'become'} empty. ` : '. ') +
        logged,
    });
    const emptyReq = `CONFIRM ${confirmPlace(u.place)} EMPTY`;
    out.push({
      id: `empty-${key}`,
      label: `${capital(at)} is empty`,
      request: emptyReq,
      confirm:
        `${emptyReq}: your word that ${at} is empty. ` +
        (others.length > 0
          ? `${u.wafer} is no longer thought to be there; it stays uncertain at ${orList(others)}. `
          : `${u.wafer} was nowhere else, so it leaves the wafer map. `) +
        logged,
    });
  }
  for (const w of uncertainWafers(r)) {
    const places = r.uncertain.filter((u) => u.wafer === w).map((u) => placeWords(u.place));
    const req = `CONFIRM ${w} GONE`;
    out.push({
      id: `gone-${w}`,
      label: `${w} is gone (out of the cell)`,
      request: req,
      confirm: `${req} removes ${w} from the wafer map (it was perhaps at ${orList(places)}): it has been taken out of the cell, or it is nowhere to be found. ${logged}`,
    });
  }
  return out;
}

/** Why a request that needs control (and perhaps an idle, homed robot outside every station) cannot be sent now. */
function refusal(
  i: RecoveryInput,
  need: { idle: boolean; homed: boolean; outside: boolean },
): string {
  if (!i.connected) return 'not connected to the controller';
  if (i.running) return `${i.running} is running`;
  if (!i.holdsControl) {
    return i.owner === 'none' ? 'take control first' : `control is held by ${i.owner}; it must release it first`;
  }
  if (!need.idle) return '';
  if (i.state === 'ERROR' || i.state === 'ESTOP') return `the robot is in ${i.state}: RESET first`;
  if (i.state === 'MOVING' || i.state === 'STOPPING') return 'the robot is moving: wait until it stands still';
  if (i.state === 'HELD') return 'a motion is held: RESUME or STOP it first';
  if (need.outside && i.report.inside !== null) return `the hand may be inside ${i.report.inside}: RETRACT (or HOME) first`;
  if (need.homed && i.homed !== true) return 'the robot is not homed: HOME first';
  return '';
}

/**
 * The steps and confirmations the panel offers for a `RECOVERY` report, which of them may be
 * pressed and why not. The controller checks everything again (NAK 120, 122, 110, 139, 140);
 * this only spares the operator a request it would refuse, and says what to do first.
 */
export function recoveryPlan(i: RecoveryInput): RecoveryPlan {
  const r = i.report;
  const needed = recoveryNeeded(r);
  const alarm = i.err === ALARM_INTERRUPTED;
  const steps: RecoveryStep[] = [];
  const step = (id: string, label: string, request: string, why: string, confirm: string | null): void => {
    steps.push({ id, label, request, enabled: why === '', why, confirm });
  };
  const speedOf = (name: string): number | null => i.stations.find((s) => s.name === name)?.speed ?? null;
  const blades = r.uncertain.filter((u) => u.place.kind === 'blade');
  // The controller never goes faster than the operator's override.
  const override = i.override !== null && i.override !== undefined && i.override > 0 ? i.override : 100;
  const capped = (pct: number): number => Math.min(pct, override);
  const retractPct = (station: string): number => capped(Math.min(speedOf(station) ?? RETRACT_SPEED_PCT, RETRACT_SPEED_PCT));
  // While a blade's wafer is uncertain everything moves at the careful speed: the slowest
  // station's, at most RETRACT_SPEED_PCT (the controller's `careful_speed_pct`); a HOME that
  // retracts with a wafer on the blade goes home at the retract's speed.
  const carefulPct =
    blades.length > 0
      ? capped(Math.max(1, i.stations.reduce((m, s) => (s.speed !== null && s.speed < m ? s.speed : m), RETRACT_SPEED_PCT)))
      : null;
  const slow = (pct: number | null): string =>
    pct === null ? '' : `, slowly (at most ${fmtNum(pct)} %: a blade may hold an unclamped wafer)`;

  if (!i.holdsControl) {
    const why = !i.connected
      ? 'not connected to the controller'
      : i.running
        ? `${i.running} is running`
        : i.owner === 'none'
          ? ''
          : `control is held by ${i.owner}; it must release it first`;
    step('control', 'Take control', 'CONTROL', why, null);
  }
  if (i.state === 'ERROR' || i.state === 'ESTOP') {
    const label = i.err ? `Reset (clears alarm ${i.err})` : 'Reset';
    step('reset', label, 'RESET', refusal(i, { idle: false, homed: false, outside: false }), null);
  }
  const inside = r.inside;
  if (inside !== null) {
    const pct = fmtNum(retractPct(inside));
    step(
      'retract',
      `Retract out of ${inside}`,
      'RETRACT',
      refusal(i, { idle: true, homed: false, outside: false }),
      `RETRACT: the hand moves straight out of ${inside} along the station's line to its approach pose, at ${pct} %, at the height it is at; ` +
        `nothing else moves. ${blades.length > 0 ? `${andList(blades.map((b) => b.wafer))} may lie unclamped on the blade: watch the cell, and stop (E-STOP) if anything catches.` : 'Watch the cell, and stop (E-STOP) if anything catches.'}`,
    );
  }
  // SENSE and MAP need a homed robot; once everything is settled, homing is ordinary work.
  if (needed && (i.homed !== true || inside !== null)) {
    const first =
      inside !== null
        ? `first the hand moves straight out of ${inside} to its approach pose at ${fmtNum(retractPct(inside))} %, then every axis goes to its home position by a PTP move`
        : 'every axis goes to its home position by a PTP move';
    step(
      'home',
      inside !== null ? `Home (out of ${inside} first)` : 'Home',
      'HOME',
      refusal(i, { idle: true, homed: false, outside: false }),
      `HOME: ${first}${slow(carefulPct ?? (inside !== null && i.bladeLoaded === true ? retractPct(inside) : null))}. Make sure the way is clear.`,
    );
  }
  for (const b of blades) {
    const blade: Blade = b.place.kind === 'blade' ? b.place.blade : 'A';
    const who = placeWords(b.place);
    const elsewhere = otherPlaces(r, b.wafer, b.place).map((o) => placeWords(o.place));
    step(
      `sense-${blade}`,
      blade === 'B' ? 'Sense blade B' : 'Sense the hand',
      blade === 'B' ? 'SENSE B' : 'SENSE',
      refusal(i, { idle: true, homed: true, outside: true }),
      `${blade === 'B' ? 'SENSE B' : 'SENSE'}: ${who === 'the hand' ? 'the hand\u2019s' : `${who}\u2019s`} vacuum is switched on and its sensor read; the robot does not move. ` +
        `If ${b.wafer} is there, the vacuum clamps it and the wafer map keeps it on the blade, certain` +
        (elsewhere.length > 0 ? ` (${andList(elsewhere)} then ${elsewhere.length === 1 ? 'becomes' : 'become'} empty)` : '') +
        `. If the sensor finds nothing, the blade is empty in the map` +
        (elsewhere.length > 0 ? ` and ${b.wafer} stays uncertain at ${orList(elsewhere)} until a MAP.` : ` and ${b.wafer}, nowhere else, leaves the map.`),
    );
  }
  const stations: string[] = [];
  for (const u of r.uncertain) if (u.place.kind === 'slot' && !stations.includes(u.place.station)) stations.push(u.place.station);
  for (const s of stations) {
    const slots = r.uncertain.filter((u) => u.place.kind === 'slot' && u.place.station === s);
    const list = slots.map((u) => `slot ${u.place.kind === 'slot' ? u.place.slot : '?'} (${u.wafer}?)`);
    const speed = speedOf(s);
    const count = i.stations.find((x) => x.name === s)?.slots;
    const sweep =
      carefulPct !== null
        ? ` at ${fmtNum(Math.min(speed ?? carefulPct, carefulPct))} % (slowly: a blade may hold an unclamped wafer)`
        : speed !== null
          ? ` at ${fmtNum(capped(speed))} %`
          : '';
    step(
      `map-${s}`,
      `Map ${s}`,
      `MAP ${s}`,
      refusal(i, { idle: true, homed: true, outside: true }),
      `MAP ${s}: the hand moves by PTP to ${s}'s approach pose below slot 1 (outside the station) and sweeps the mapping sensor straight up past ${count ? `slot ${count}` : 'the last slot'}${sweep}. ` +
        `The wafer map takes what the sensor finds in every slot of ${s}: ${andList(list)} becomes that wafer if one is there, empty if not.`,
    );
  }

  const confirms = needed ? confirmChoices(r) : [];
  const confirmWhy = refusal(i, { idle: false, homed: false, outside: false });
  const parts: string[] = [];
  if (r.uncertain.length > 0) parts.push(plural(r.uncertain.length, 'uncertain place'));
  if (inside !== null) parts.push(`the hand may be inside ${inside}`);
  const summary = needed
    ? `Recovery needed: ${parts.join(' · ')}`
    : `Alarm ${ALARM_INTERRUPTED}: nothing is uncertain any more; RESET clears it`;
  return {
    shown: needed || alarm,
    settled: !needed,
    steps,
    next: steps.length > 0 ? steps[0].id : null,
    confirms,
    confirmEnabled: confirmWhy === '',
    confirmWhy,
    summary,
  };
}

/** A reply as the panel shows it: kind (`nak`, `inf`, …) and text. */
export interface ReplyView {
  /** `out`: sent, no reply yet; `ack`: accepted (and, with a final, running); `inf`, `abs`, `nak`. */
  kind: 'out' | 'ack' | 'nak' | 'inf' | 'abs';
  text: string;
}

/** A reply line's words after its verb and id, without a checksum (`ACK 7 owner=gui0` → `owner=gui0`). */
function replyRest(line: string, verb: string): string {
  return line.replace(new RegExp(`^\\s*${verb}(?:[ \\t]+\\d+)?[ \\t]*`), '').replace(/\*[0-9A-Fa-f]{2}\s*$/, '').trim();
}

/**
 * What the panel shows for the first reply to `request`: `NAK 139 <text> (SENSE)`, or `ACK
 * SENSE (running)` while its `INF`/`ABS` is to come (`running`), or `ACK CONFIRM …: <text>`.
 */
export function firstReplyView(request: string, first: FirstReply, running: boolean): ReplyView {
  if (first.kind === 'NAK') return { kind: 'nak', text: `NAK ${first.code} ${first.text} (${request})` };
  const rest = replyRest(first.line, 'ACK');
  return { kind: 'ack', text: `ACK ${request}${rest ? `: ${rest}` : ''}${running ? ' (running)' : ''}` };
}

/** What the panel shows for the end of `request`: `INF SENSE finished: none`, `ABS 201 <text> (HOME)`. */
export function finalReplyView(request: string, final: FinalReply): ReplyView {
  if (final.kind === 'INF') {
    const rest = replyRest(final.line, 'INF');
    return { kind: 'inf', text: `INF ${request} finished${rest ? `: ${rest}` : ''}` };
  }
  return { kind: 'abs', text: `ABS ${final.code ? `${final.code} ` : ''}${final.text} (${request})` };
}

// ---------------------------------------------------------------------------------------------
// The DOM


export interface RecoveryHandle {
  /** The banner for the header (hidden while nothing is to recover). */
  banner: HTMLElement;
  /** The panel (a box over the tabs; append it to the page). */
  panel: HTMLElement;
  /** Show or hide the panel (the banner's button and ✕ do this). */
  open(): void;
  close(): void;
  dispose(): void;
}

/**
 * The recovery banner and panel, kept from `store` (RECOVERY), the controller model (state,
 * homed, control, error), the wafer map (whether a blade is loaded) and the stations (speeds).
 */
export function mountRecovery(deps: {
  store: RecoveryStore;
  model: ControllerModel;
  cmd: Commander;
  wafers: WaferStore;
  stations: Pick<StationsHandle, 'stations' | 'onChange'>;
}): RecoveryHandle {
  const { store, model, cmd, wafers, stations } = deps;

  // ---- banner ----
  const bannerText = h('span', { class: 'recovery-banner-text', 'data-testid': 'recovery-banner-text' });
  const openBtn = h('button', { 'data-testid': 'recovery-open', title: 'Show the recovery panel', onclick: () => open() }, 'Recovery…');
  const banner = h('div', { class: 'recovery-banner', 'data-testid': 'recovery-banner', role: 'status', hidden: true }, '\u26a0', bannerText, openBtn);

  // ---- panel ----
  const note = h('div', { class: 'recovery-note', 'data-testid': 'recovery-note' });
  const handPose = h('span', { class: 'recovery-hand', 'data-testid': 'recovery-hand' });
  const insideChip = h('span', { class: 'recovery-inside', 'data-testid': 'recovery-inside', 'data-inside': '0' });
  const uncertainList = h('ul', { class: 'recovery-uncertain', 'data-testid': 'recovery-uncertain' });
  const stepsList = h('ol', { class: 'recovery-steps', 'data-testid': 'recovery-steps' });
  const confirmSel = h('select', { 'data-testid': 'recovery-confirm-choice', 'aria-label': 'What you see' });
  const confirmBtn = h('button', { class: 'btn warn', 'data-testid': 'recovery-confirm', onclick: () => askConfirm() }, 'Confirm\u2026');
  const confirmWhy = h('span', { class: 'recovery-why', 'data-testid': 'recovery-confirm-why' });
  const confirmSection = h(
    'div',
    { 'data-testid': 'recovery-confirm-section' },
    h('h3', {}, 'Or confirm what you see'),
    h('div', { class: 'recovery-confirm-row' }, confirmSel, confirmBtn, confirmWhy),
  );
  const settledNote = h('div', { class: 'recovery-note', 'data-testid': 'recovery-settled', hidden: true });
  const result = h('div', { class: 'recovery-result', 'data-testid': 'recovery-result' });
  const doneList = h('ul', { class: 'recovery-done', 'data-testid': 'recovery-done' });
  const doneSection = h('div', { hidden: true }, h('h3', {}, 'Done so far'), doneList);
  const suggest = h('div', { class: 'recovery-suggest', 'data-testid': 'recovery-suggest' });
  const panel = h(
    'aside',
    { class: 'recovery-panel', 'data-testid': 'recovery-panel', role: 'dialog', 'aria-label': 'Recovery', hidden: true },
    h(
      'div',
      { class: 'recovery-head' },
      h('h2', {}, 'Recovery after an interrupted transfer'),
      h('span', { class: 'spacer' }),
      h('button', { class: 'btn small', 'data-testid': 'recovery-close', title: 'Hide (the banner stays)', onclick: () => close() }, '\u2715'),
    ),
    settledNote,
    h('div', { 'data-testid': 'recovery-what' }, h('h3', {}, 'What happened'), note),
    h('h3', {}, 'The hand'),
    h('div', {}, handPose, insideChip),
    h('div', { 'data-testid': 'recovery-uncertain-section' }, h('h3', {}, 'Uncertain'), uncertainList),
    h('h3', {}, 'Next steps'),
    stepsList,
    confirmSection,
    result,
    doneSection,
    suggest,
  );

  // ---- the confirmation dialog ----
  const dlgTitle = h('h3', { 'data-testid': 'recovery-dialog-title' });
  const dlgText = h('p', { 'data-testid': 'recovery-dialog-text' });
  const dlgRequest = h('code', { 'data-testid': 'recovery-dialog-request' });
  const dlgWhy = h('p', { class: 'recovery-dialog-why', 'data-testid': 'recovery-dialog-why', role: 'alert' });
  const dlgOk = h('button', { class: 'btn warn', 'data-testid': 'recovery-dialog-ok' }, 'Send');
  const dlgCancel = h('button', { class: 'btn', 'data-testid': 'recovery-dialog-cancel' }, 'Cancel');
  const dialog = h(
    'dialog',
    { class: 'recovery-dialog', 'data-testid': 'recovery-dialog' },
    dlgTitle,
    dlgText,
    h('p', {}, 'Sends ', dlgRequest),
    dlgWhy,
    h('div', { class: 'recovery-dialog-buttons' }, dlgCancel, dlgOk),
  );
  /** Hides the dialog's layer (null while it is not shown). */
  let hideLayer: (() => void) | null = null;
  /** What the open dialog asks about: a step's or a confirmation's id, and its request. */
  let asking: { kind: 'step' | 'confirm'; id: string; request: string } | null = null;
  /** Why the open dialog's request may not be sent any more ('' while it may): the plan now. */
  function askingWhy(): string {
    if (!asking) return '';
    if (running) return `${running} is running`;
    if (!plan) return 'nothing to recover any more';
    if (asking.kind === 'step') {
      const s = plan.steps.find((x) => x.id === asking?.id);
      if (!s) return 'this step is no longer needed';
      return s.enabled ? '' : s.why;
    }
    if (!plan.confirms.some((c) => c.id === asking?.id)) return 'this place is no longer uncertain';
    return plan.confirmEnabled ? '' : plan.confirmWhy;
  }
  function closeDialog(): void {
    asking = null;
    const hide = hideLayer;
    hideLayer = null;
    hide?.();
  }
  dlgCancel.addEventListener('click', () => closeDialog());
  dlgOk.addEventListener('click', () => {
    // The state may have changed while the dialog was open (another source stopped the
    // robot, a RECOVERY reply settled the place): send only what the plan still allows.
    if (!asking || askingWhy() !== '') return;
    const req = asking.request;
    closeDialog();
    void run(req);
  });
  function ask(what: { kind: 'step' | 'confirm'; id: string; request: string }, title: string, text: string): void {
    setText(dlgTitle, title);
    setText(dlgText, text);
    setText(dlgRequest, what.request);
    dlgOk.textContent = `Send ${what.request}`;
    asking = what;
    renderDialog();
    // Never modal: the E-STOP it names stays pressable (layer.ts). Escape sends nothing.
    hideLayer?.();
    hideLayer = showLayer(dialog, () => closeDialog());
  }
  /** The open dialog's Send: disabled, with the reason, once its request may not be sent. */
  function renderDialog(): void {
    const why = askingWhy();
    dlgOk.disabled = why !== '';
    setText(dlgWhy, why === '' ? '' : `Not sent now: ${why}.`);
  }

  // ---- state ----
  let plan: RecoveryPlan | null = null;
  let running: string | null = null;
  let isOpen = false;
  let wasShown = false;

  function open(): void {
    isOpen = true;
    render();
  }
  function close(): void {
    isOpen = false;
    render();
  }

  function show(r: ReplyView | null): void {
    setAttr(result, 'data-kind', r?.kind ?? '');
    setText(result, r?.text ?? '');
  }

  async function run(request: string): Promise<void> {
    if (running) return;
    running = request;
    show({ kind: 'out', text: `> ${request}` });
    render();
    try {
      const sent = await cmd.send(request);
      if (!sent) {
        show({ kind: 'nak', text: `${request}: not sent (not connected)` });
        return;
      }
      const { first, final } = sent;
      show(firstReplyView(request, first, final !== null));
      if (final) {
        const f = await final.catch(
          (e: unknown): FinalReply => ({ kind: 'ABS', id: 0, code: 0, text: e instanceof Error ? e.message : String(e), line: '' }),
        );
        show(finalReplyView(request, f));
      }
    } finally {
      running = null;
      // The map, the hand and the state may have changed: ask again.
      void store.refresh();
      model.refresh();
      schedule();
    }
  }

  function askStep(s: RecoveryStep): void {
    if (!s.enabled || running) return;
    if (s.confirm === null) void run(s.request);
    else ask({ kind: 'step', id: s.id, request: s.request }, s.label, s.confirm);
  }

  function askConfirm(): void {
    const c = plan?.confirms.find((x) => x.id === confirmSel.value);
    if (!c || !plan?.confirmEnabled || running) return;
    ask({ kind: 'confirm', id: c.id, request: c.request }, `Confirm: ${c.label}`, c.confirm);
  }

  // ---- drawing ----
  let stepsKey = '';
  const stepButtons = new Map<string, { li: HTMLElement; btn: HTMLButtonElement; why: HTMLElement }>();
  let confirmKey = '';
  let uncertainKey = '';

  function render(): void {
    const st = store.state();
    const v = model.v;
    const report = st.report;
    const wm = wafers.state().map;
    if (!report || st.available !== true) {
      plan = null;
      banner.hidden = true;
      panel.hidden = true;
      wasShown = false;
      closeDialog();
      return;
    }
    plan = recoveryPlan({
      report,
      connected: v.connected,
      state: v.state,
      homed: v.homed,
      owner: v.owner,
      holdsControl: model.holdsControl(),
      err: v.err,
      running,
      stations: stations.stations(),
      bladeLoaded: wm.hand !== null || wm.handB !== null,
      override: v.speed,
    });
    // Opens by itself when recovery becomes needed (a restart found something).
    if (plan.shown && !wasShown) isOpen = true;
    wasShown = plan.shown;
    banner.hidden = !plan.shown;
    panel.hidden = !plan.shown || !isOpen;
    setText(bannerText, plan.summary);
    banner.title = plan.summary;
    if (panel.hidden) closeDialog();
    else if (asking) renderDialog();
    if (!plan.shown) return;

    settledNote.hidden = !plan.settled;
    setText(settledNote, plan.settled ? `Nothing is uncertain any more and the hand is outside every station. RESET clears alarm ${ALARM_INTERRUPTED}.` : '');
    setText(note, report.note ?? 'The controller noted nothing more.');
    const hp = report.hand;
    setText(handPose, hp ? `x=${fmtNum(hp.x)} y=${fmtNum(hp.y)} z=${fmtNum(hp.z)} yaw=${fmtNum(hp.yaw)}` : 'unknown');
    setAttr(insideChip, 'data-inside', report.inside !== null ? '1' : '0');
    setText(insideChip, report.inside !== null ? `may be inside ${report.inside}` : 'outside every station');

    const uk = report.uncertain.map((u) => `${placeText(u.place)}:${u.wafer}`).join(' ');
    if (uk !== uncertainKey) {
      uncertainKey = uk;
      uncertainList.replaceChildren(
        ...report.uncertain.map((u) =>
          h(
            'li',
            { 'data-testid': 'recovery-uncertain-place', 'data-place': placeText(u.place), 'data-wafer': u.wafer },
            h('span', { class: 'recovery-wafer' }, `${u.wafer}?`),
            `${u.place.kind === 'blade' ? 'on' : 'in'} ${placeWords(u.place)}: perhaps there, perhaps not`,
          ),
        ),
      );
      if (report.uncertain.length === 0) uncertainList.append(h('li', {}, 'Nothing.'));
    }

    const sk = plan.steps.map((s) => `${s.id}\u0000${s.label}`).join('\u0001');
    if (sk !== stepsKey) {
      stepsKey = sk;
      stepButtons.clear();
      stepsList.replaceChildren();
      for (const s of plan.steps) {
        const btn = h('button', { class: 'btn primary', 'data-testid': `recovery-step-${s.id}` }, s.label);
        const why = h('span', { class: 'recovery-why', 'data-testid': `recovery-why-${s.id}` });
        const li = h('li', { 'data-step': s.id }, btn, why);
        btn.addEventListener('click', () => {
          const now = plan?.steps.find((x) => x.id === s.id);
          if (now) askStep(now);
        });
        stepButtons.set(s.id, { li, btn, why });
        stepsList.append(li);
      }
      if (plan.steps.length === 0) stepsList.append(h('li', {}, 'Nothing to do.'));
    }
    for (const s of plan.steps) {
      const b = stepButtons.get(s.id);
      if (!b) continue;
      b.btn.disabled = !s.enabled;
      setAttr(b.btn, 'title', s.enabled ? `Send ${s.request}` : `${s.request}: ${s.why}`);
      setAttr(b.li, 'data-next', plan.next === s.id ? '1' : '0');
      setText(b.why, s.enabled ? (plan.next === s.id ? '\u2190 next' : '') : s.why);
    }

    const ck = plan.confirms.map((c) => c.id).join(' ');
    if (ck !== confirmKey) {
      confirmKey = ck;
      const keep = confirmSel.value;
      confirmSel.replaceChildren(...plan.confirms.map((c) => h('option', { value: c.id }, c.label)));
      if (plan.confirms.some((c) => c.id === keep)) confirmSel.value = keep;
    }
    confirmSection.hidden = plan.confirms.length === 0;
    confirmBtn.disabled = !plan.confirmEnabled || plan.confirms.length === 0;
    setText(confirmWhy, plan.confirmEnabled ? '' : plan.confirmWhy);

    doneSection.hidden = st.done.length === 0;
    const dk = st.done.join('\n');
    if (doneList.dataset.key !== dk) {
      doneList.dataset.key = dk;
      doneList.replaceChildren(...st.done.map((d) => h('li', {}, d)));
    }
    setText(suggest, report.next.length > 0 ? `The controller suggests: ${report.next.join(', ')}.` : '');
  }

  // Controller updates come every frame while the robot moves; redraw only when what the
  // panel depends on changed.
  const schedule = frameThrottle(render);
  let ctl = '';
  const unsubs = [
    store.onChange(() => schedule()),
    wafers.onChange(() => schedule()),
    stations.onChange(() => schedule()),
    model.onChange((v) => {
      const k = `${v.connected}|${v.state}|${v.homed}|${v.owner}|${v.me}|${v.err}|${v.speed}`;
      if (k === ctl) return;
      ctl = k;
      schedule();
    }),
  ];
  render();

  return {
    banner,
    panel,
    open,
    close,
    dispose() {
      for (const u of unsubs) u();
      closeDialog();
      dialog.remove();
      banner.remove();
      panel.remove();
    },
  };
}
