// The Wafers panel: the wafer map as an operator reads a cassette — one column per station,
// its highest slot on top, each slot coloured by what it holds — with the hand's wafer, the
// transfer in progress, and GET / PUT / MAP for the selected slot or station. Requests go
// through the Commander, so they and their ACK/NAK and INF/ABS appear in the command log.
//
// On a dual-blade robot the panel also shows blade B's wafer, lets GET / PUT use blade B
// (`GET LP1 3 B`; blade A's requests stay `GET LP1 3`, as on a single-hand robot) and offers
// SWAP, which exchanges the wafer of one blade with the slot's in one visit.
//
// The decisions (what a slot shows, which button is enabled and why) are plain functions of
// the state, unit-tested without a DOM; `mountWaferPanel` only draws them.

import type { RobotInfo } from '../protocol/bus';
import type { Commander } from '../protocol/commander';
import type { ControllerModel } from '../protocol/controller-model';
import { programRefusal } from '../protocol/motion-gate';
import type { ProgramTracker } from '../protocol/program-tracker';
import { h, setAttr, setText } from '../dom';
import { frameThrottle } from '../frame-throttle';
import type { StationInfo, StationsHandle } from '../cell/stations';
import {
  formatPending,
  type Blade,
  type PendingTransfer,
  type SlotState,
  type SlotToken,
  type WaferMap,
  type WaferState,
  type WaferStore,
} from '../cell/wafers';
import './wafer-panel.css';

/** The slot (or, with `slot` null, only the station) the operator clicked. */
export interface WaferSelection {
  station: string;
  slot: number | null;
}

/** One button: whether it may be pressed, the request it sends, and why not. */
export interface WaferAction {
  enabled: boolean;
  /** `GET LP1 3`, `PUT LP1 3 B`, `SWAP LP1 3`, `MAP LP1`; null when nothing is selected. */
  request: string | null;
  /** Why the button is disabled ('' when enabled). */
  why: string;
}

export interface WaferActions {
  get: WaferAction;
  put: WaferAction;
  map: WaferAction;
  /** SWAP, only on a dual-blade robot (null: the robot has no blade B, no button). */
  swap: WaferAction | null;
}

/**
 * Whether the robot has blade B: its `ROBOT` reply gave `blade_b=`, or the map has a wafer on
 * blade B (so that a wafer there is never hidden, even before `ROBOT` has been answered).
 */
export function isDualBlade(robot: Pick<RobotInfo, 'bladeB'> | null, map: WaferMap): boolean {
  return (robot?.bladeB ?? null) !== null || map.handB !== null;
}

/** The wafer on a blade, or null. */
function onBlade(map: WaferMap, blade: Blade): string | null {
  return blade === 'B' ? map.handB : map.hand;
}

/** A blade in reasons: `the hand` for blade A (as a single-hand robot calls it), `blade B`. */
function bladeWords(blade: Blade): string {
  return blade === 'B' ? 'blade B' : 'the hand';
}

/** What the transfer in progress says: `GET LP1 slot 3 (W3) with blade B in progress`. */
export function pendingText(p: PendingTransfer | null): string {
  if (!p) return 'no transfer';
  const with_ = p.blade === 'B' ? ' with blade B' : '';
  return `${p.kind === 'get' ? 'GET' : 'PUT'} ${p.station} slot ${p.slot} (${p.wafer})${with_} in progress`;
}

/** What a slot shows as its text. */
export function slotLabel(t: SlotToken): string {
  switch (t.state) {
    case 'wafer':
      return t.wafer ?? 'wafer';
    case 'empty':
      return '';
    case 'unknown':
      return '?';
    case 'double':
      return 'double';
    case 'cross':
      return 'cross';
    case 'uncertain':
      return `${t.wafer ?? 'wafer'}?`;
  }
}

const STATE_WORDS: Record<SlotState, string> = {
  wafer: 'a wafer',
  empty: 'empty',
  unknown: 'not mapped yet',
  double: 'a double wafer (two wafers in one slot)',
  cross: 'a cross-slotted wafer (resting in two slots)',
  uncertain: 'perhaps a wafer (uncertain after an interrupted transfer)',
};

/** The tooltip of a slot: `LP1 slot 3: W3`, `LP2 slot 1: perhaps W1 (uncertain …)`. */
export function slotTitle(station: string, slot: number, t: SlotToken): string {
  if (t.state === 'uncertain') {
    return `${station} slot ${slot}: perhaps ${t.wafer ?? 'a wafer'}, perhaps empty (uncertain after an interrupted transfer: MAP ${station} or CONFIRM it)`;
  }
  return `${station} slot ${slot}: ${t.state === 'wafer' ? (t.wafer ?? 'a wafer') : STATE_WORDS[t.state]}`;
}

/** What a blade shows: `empty`, `W3`, or `W3? (uncertain: …)`. */
export function bladeText(wafer: string | null, uncertain: boolean): string {
  if (wafer === null) return 'empty';
  return uncertain ? `${wafer}? (uncertain: perhaps on the blade; SENSE or CONFIRM it)` : wafer;
}

/** The selection kept valid for a new map: null when its station is gone, no slot when its slot is. */
export function keepSelection(map: WaferMap, sel: WaferSelection | null): WaferSelection | null {
  if (!sel) return null;
  const slots = map.stations.get(sel.station);
  if (!slots) return null;
  if (sel.slot !== null && (sel.slot < 1 || sel.slot > slots.length)) return { station: sel.station, slot: null };
  return sel;
}

const ok = (request: string): WaferAction => ({ enabled: true, request, why: '' });
const no = (request: string | null, why: string): WaferAction => ({ enabled: false, request, why });

/**
 * Which of GET, PUT, MAP and (on a dual-blade robot) SWAP may be pressed, and why not. The
 * controller checks everything again (NAK 130-138); this only spares the operator requests
 * the map already says it would refuse.
 */
export function waferActions(input: {
  connected: boolean;
  /** May this page command motions (nobody or this page holds control)? */
  mayCommand: boolean;
  state: WaferState;
  selection: WaferSelection | null;
  /** A GET, PUT, SWAP or MAP this page sent that has not ended yet (`GET LP1 3`), or null. */
  running?: string | null;
  /**
   * Why a program forbids transfers now (`wafer_cycle is running: ABORT it (Editor) first`),
   * '' or absent when none runs: the controller refuses them (127) while one runs.
   */
  program?: string;
  /** Does the robot have blade B (`isDualBlade`)? Default no: GET/PUT use the hand, no SWAP. */
  dualBlade?: boolean;
  /** The blade GET and PUT use on a dual-blade robot (default A; A on a single-hand robot). */
  blade?: Blade;
}): WaferActions {
  const { state, selection: sel } = input;
  const map = state.map;
  const dual = input.dualBlade === true;
  const blade: Blade = dual && input.blade === 'B' ? 'B' : 'A';
  const slots = sel ? map.stations.get(sel.station) : undefined;
  // Blade A is the default the controller assumes: its requests stay as they always were.
  const bladeArg = blade === 'B' ? ' B' : '';
  const slotReq = (verb: string, arg = ''): string | null =>
    sel && sel.slot !== null ? `${verb} ${sel.station} ${sel.slot}${arg}` : null;
  const getReq = slotReq('GET', bladeArg);
  const putReq = slotReq('PUT', bladeArg);
  const swapReq = slotReq('SWAP');
  const mapReq = sel ? `MAP ${sel.station}` : null;
  const swapOr = (a: WaferAction): WaferAction | null => (dual ? a : null);

  const general = !input.connected
    ? 'not connected to the controller'
    : state.available === false
      ? 'this controller has no wafer cell'
      : state.available === null
        ? 'waiting for the wafer map (WAFERS)'
        : !input.mayCommand
          ? 'control is held by another source; take control first'
          : input.program
            ? input.program
            : input.running
            ? `${input.running} is running`
            : map.pending
              ? `a transfer is in progress (${formatPending(map.pending)})`
              : '';
  if (general) {
    return {
      get: no(getReq, general),
      put: no(putReq, general),
      map: no(mapReq, general),
      swap: swapOr(no(swapReq, general)),
    };
  }

  const mapAction = mapReq && slots ? ok(mapReq) : no(mapReq, 'select a station to map');
  if (!sel || sel.slot === null || !slots || getReq === null || putReq === null || swapReq === null) {
    const why = 'select a slot';
    return { get: no(getReq, why), put: no(putReq, why), map: mapAction, swap: swapOr(no(swapReq, why)) };
  }
  const where = `${sel.station} slot ${sel.slot}`;
  const t: SlotToken | undefined = slots[sel.slot - 1];
  const fault = (s: SlotState): string => `${where} holds ${STATE_WORDS[s]}: clear it and MAP ${sel.station}`;
  const unmapped = `${where} is not mapped yet: MAP ${sel.station} first`;
  const uncertain = (w: string | null): string =>
    `${where} is uncertain (perhaps ${w ?? 'a wafer'}): MAP ${sel.station} or CONFIRM it first`;
  /** Why the slot has no wafer to take ('' when it has one), for GET and SWAP. */
  const noWaferIn = (): string => {
    if (!t) return `${where} does not exist`;
    if (t.state === 'wafer') return '';
    if (t.state === 'empty') return `${where} is empty`;
    if (t.state === 'unknown') return unmapped;
    if (t.state === 'uncertain') return uncertain(t.wafer);
    return fault(t.state);
  };
  /** Why the slot cannot take a wafer ('' when it is empty), for PUT. */
  const noRoomIn = (): string => {
    if (!t) return `${where} does not exist`;
    if (t.state === 'empty') return '';
    if (t.state === 'wafer') return `${where} holds ${t.wafer ?? 'a wafer'}`;
    if (t.state === 'unknown') return unmapped;
    if (t.state === 'uncertain') return uncertain(t.wafer);
    return fault(t.state);
  };
  const check = (req: string, why: string): WaferAction => (why === '' ? ok(req) : no(req, why));

  const held = onBlade(map, blade);
  const doubt = (b: Blade): string =>
    `${bladeWords(b)} may hold ${onBlade(map, b) ?? 'a wafer'} (uncertain): SENSE or CONFIRM it first`;
  const heldUncertain = blade === 'B' ? map.handBUncertain : map.handUncertain;
  const get =
    held === null
      ? check(getReq, noWaferIn())
      : no(getReq, heldUncertain ? doubt(blade) : `${bladeWords(blade)} already holds ${held}`);
  const put =
    held === null
      ? no(putReq, `${bladeWords(blade)} holds no wafer`)
      : heldUncertain
        ? no(putReq, doubt(blade))
        : check(putReq, noRoomIn());

  // SWAP takes the slot's wafer with the empty blade and puts the other blade's there: it
  // needs exactly one blade loaded.
  let swap: WaferAction;
  if ((map.hand !== null && map.handUncertain) || (map.handB !== null && map.handBUncertain)) {
    swap = no(swapReq, doubt(map.hand !== null && map.handUncertain ? 'A' : 'B'));
  } else if (map.hand !== null && map.handB !== null) {
    swap = no(swapReq, `both blades hold a wafer (${map.hand}, ${map.handB}): SWAP needs one empty`);
  } else if (map.hand === null && map.handB === null) {
    swap = no(swapReq, 'neither blade holds a wafer to swap in');
  } else swap = check(swapReq, noWaferIn());

  return { get, put, map: mapAction, swap: swapOr(swap) };
}

/**
 * One line on why buttons are disabled: the reason they all share, or each button's own
 * (`GET: LP1 slot 3 is empty · MAP: …`); '' when all are enabled. A SWAP the robot cannot
 * make (no blade B) has no button and no reason.
 */
export function actionsHint(a: WaferActions): string {
  const shown = (['get', 'put', 'map', 'swap'] as const).flatMap((k) => {
    const action = a[k];
    return action ? [{ k, action }] : [];
  });
  const whys = shown.filter((x) => x.action.why !== '');
  if (whys.length === 0) return '';
  if (whys.length === shown.length && whys.every((x) => x.action.why === whys[0].action.why)) return whys[0].action.why;
  return whys.map((x) => `${x.k.toUpperCase()}: ${x.action.why}`).join(' · ');
}

/** `load_port` → `load port`. */
function kindWords(kind: string): string {
  return kind.replace(/_/g, ' ');
}


export interface WaferPanel {
  resize(): void;
  /** The current selection (for tests and the console). */
  selection(): WaferSelection | null;
  dispose(): void;
}

/**
 * Draw the Wafers panel into `el`. `stations` (optional) names each station's kind in its
 * column head.
 */
export function mountWaferPanel(
  el: HTMLElement,
  store: WaferStore,
  model: ControllerModel,
  cmd: Commander,
  stations?: Pick<StationsHandle, 'stations' | 'onChange'>,
  program?: Pick<ProgramTracker, 'v' | 'onChange'>,
): WaferPanel {
  el.classList.add('wafer-panel');
  el.replaceChildren();

  let selection: WaferSelection | null = null;
  let actions: WaferActions | null = null;

  const hand = h('span', { class: 'wafer-hand', 'data-testid': 'wafer-hand', 'data-wafer': '' }, 'empty');
  // Blade B and the blade choice exist only on a dual-blade robot: hidden otherwise.
  const handB = h('span', { class: 'wafer-hand-b', 'data-testid': 'wafer-hand-b', 'data-wafer': '' }, 'empty');
  const bladeBWrap = h('span', { class: 'wafer-blade-b', hidden: true }, h('span', { class: 'wafer-label' }, '· blade B'), handB);
  let blade: Blade = 'A';
  const bladeSel = h(
    'select',
    {
      'data-testid': 'wafer-blade',
      'aria-label': 'Blade for GET and PUT',
      title: 'The blade GET and PUT use',
      onchange: () => {
        blade = bladeSel.value === 'B' ? 'B' : 'A';
        render();
      },
    },
    h('option', { value: 'A' }, 'blade A (hand)'),
    h('option', { value: 'B' }, 'blade B'),
  );
  const bladeChoice = h('label', { class: 'wafer-blade-choice', hidden: true }, h('span', { class: 'wafer-label' }, 'GET/PUT with'), bladeSel);
  const pending = h('span', { class: 'wafer-pending', 'data-testid': 'wafer-pending', 'data-pending': '0' }, 'no transfer');
  const selected = h('span', { class: 'wafer-selection', 'data-testid': 'wafer-selection' }, 'nothing selected');
  let running: string | null = null;
  async function run(which: keyof WaferActions): Promise<void> {
    const a = actions?.[which];
    if (!a?.enabled || !a.request || running) return;
    running = a.request;
    render();
    try {
      const sent = await cmd.send(a.request);
      if (sent?.final) await sent.final.catch(() => undefined);
    } finally {
      running = null;
      schedule();
    }
  }
  const press = (which: keyof WaferActions) => () => void run(which);
  const getBtn = h('button', { class: 'btn go', 'data-testid': 'wafer-get', onclick: press('get') }, 'GET');
  const putBtn = h('button', { class: 'btn go', 'data-testid': 'wafer-put', onclick: press('put') }, 'PUT');
  const mapBtn = h('button', { class: 'btn primary', 'data-testid': 'wafer-map', onclick: press('map') }, 'MAP');
  const swapBtn = h('button', { class: 'btn go', 'data-testid': 'wafer-swap', hidden: true, onclick: press('swap') }, 'SWAP');
  const refreshBtn = h(
    'button',
    { class: 'btn small', 'data-testid': 'wafer-refresh', title: 'Ask the controller for the whole map again (WAFERS)', onclick: () => void store.refresh() },
    'Refresh',
  );
  const hint = h('div', { class: 'wafer-hint', 'data-testid': 'wafer-hint' });
  const columns = h('div', { class: 'wafer-stations', 'data-testid': 'wafer-stations' });

  const legendItem = (cls: string, text: string) =>
    h('span', { class: 'wlegend-item' }, h('span', { class: `wlegend-swatch ${cls}` }), text);
  const legend = h(
    'div',
    { class: 'wafer-legend', 'data-testid': 'wafer-legend' },
    legendItem('wlegend-wafer', 'wafer (id)'),
    legendItem('wlegend-empty', 'empty'),
    legendItem('wlegend-unknown', 'not mapped'),
    legendItem('wlegend-double', 'double'),
    legendItem('wlegend-cross', 'cross-slotted'),
    legendItem('wlegend-uncertain', 'uncertain (W3?: perhaps, perhaps not)'),
    legendItem('wlegend-pending', 'transfer in progress'),
    legendItem('wlegend-selected', 'selected'),
    h('span', {}, 'Slot 1 is at the bottom of each column, as in a cassette.'),
  );

  el.append(
    h(
      'div',
      { class: 'toolbar' },
      h('span', { class: 'wafer-label' }, 'Hand'),
      hand,
      bladeBWrap,
      pending,
      h('span', { class: 'spacer' }),
      selected,
      bladeChoice,
      getBtn,
      putBtn,
      swapBtn,
      mapBtn,
      refreshBtn,
    ),
    hint,
    columns,
    legend,
  );

  // ---- station columns: rebuilt when the stations or their slot counts change ----
  interface Column {
    col: HTMLElement;
    kind: HTMLElement;
    slots: HTMLButtonElement[]; // index 0 = slot 1
  }
  const cols = new Map<string, Column>();
  let layout: string | null = null; // the stations and slot counts the columns were built for

  function select(sel: WaferSelection): void {
    selection = sel;
    render();
  }

  function build(map: WaferMap): void {
    cols.clear();
    columns.replaceChildren();
    if (map.stations.size === 0) {
      columns.append(h('div', { class: 'wafer-empty', 'data-testid': 'wafer-none' }, 'No stations in the wafer map.'));
      return;
    }
    for (const [name, slots] of map.stations) {
      const kind = h('span', { class: 'wcol-kind' });
      const head = h(
        'button',
        { class: 'wcol-head', title: `Select ${name} (for MAP)`, onclick: () => select({ station: name, slot: null }) },
        h('span', { class: 'wcol-name' }, name),
        kind,
      );
      const list = h('div', { class: 'wslots' });
      const buttons: HTMLButtonElement[] = [];
      for (let n = 1; n <= slots.length; n++) {
        const b = h(
          'button',
          {
            class: 'wslot',
            'data-testid': `wafer-slot-${name}-${n}`,
            'data-slot': n,
            'data-state': 'unknown',
            'data-wafer': '',
            'data-selected': '0',
            'data-pending': '0',
            onclick: () => select({ station: name, slot: n }),
          },
          h('span', { class: 'wslot-n' }, String(n)),
          h('span', { class: 'wslot-label' }),
        );
        buttons.push(b);
      }
      // Highest slot on top, like a cassette seen from the front.
      for (let i = buttons.length - 1; i >= 0; i--) list.append(buttons[i]);
      const col = h('div', { class: 'wcol', 'data-testid': `wafer-station-${name}`, 'data-selected': '0' }, head, list);
      columns.append(col);
      cols.set(name, { col, kind, slots: buttons });
    }
  }

  function render(): void {
    const st = store.state();
    const map = st.map;
    const v = model.v;
    const key = [...map.stations].map(([n, s]) => `${n}:${s.length}`).join(' ');
    if (key !== layout) {
      layout = key;
      build(map);
    }
    selection = keepSelection(map, selection);

    const info = new Map<string, StationInfo>((stations?.stations() ?? []).map((s) => [s.name, s]));
    for (const [name, c] of cols) {
      const slots = map.stations.get(name) ?? [];
      const si = info.get(name);
      setText(c.kind, si ? `${kindWords(si.kind)} · ${slots.length} slot${slots.length === 1 ? '' : 's'}` : `${slots.length} slot${slots.length === 1 ? '' : 's'}`);
      setAttr(c.col, 'data-selected', selection?.station === name ? '1' : '0');
      c.slots.forEach((b, i) => {
        const t = slots[i];
        if (!t) return;
        const n = i + 1;
        setAttr(b, 'data-state', t.state);
        setAttr(b, 'data-wafer', t.wafer ?? '');
        setAttr(b, 'data-selected', selection?.station === name && selection.slot === n ? '1' : '0');
        const p = map.pending;
        setAttr(b, 'data-pending', p && p.station === name && p.slot === n ? '1' : '0');
        setAttr(b, 'title', slotTitle(name, n, t));
        setAttr(b, 'aria-pressed', selection?.station === name && selection.slot === n ? 'true' : 'false');
        setText(b.lastElementChild as Element, slotLabel(t));
      });
    }

    setAttr(hand, 'data-wafer', map.hand ?? '');
    setAttr(hand, 'data-uncertain', map.hand !== null && map.handUncertain ? '1' : '0');
    setText(hand, bladeText(map.hand, map.handUncertain));
    const dual = isDualBlade(v.robot, map);
    bladeBWrap.hidden = !dual;
    bladeChoice.hidden = !dual;
    setAttr(handB, 'data-wafer', map.handB ?? '');
    setAttr(handB, 'data-uncertain', map.handB !== null && map.handBUncertain ? '1' : '0');
    setText(handB, bladeText(map.handB, map.handBUncertain));
    const p = map.pending;
    setAttr(pending, 'data-pending', p ? '1' : '0');
    setAttr(pending, 'data-kind', p ? p.kind : '');
    setAttr(pending, 'data-blade', p ? p.blade : '');
    setText(pending, pendingText(p));
    setText(selected, selection ? (selection.slot === null ? selection.station : `${selection.station} slot ${selection.slot}`) : 'nothing selected');

    actions = waferActions({
      connected: v.connected,
      mayCommand: model.mayCommand(),
      state: st,
      selection,
      running,
      dualBlade: dual,
      blade,
      program: program ? programRefusal(program.v.state, program.v.program) : '',
    });
    const btn = (b: HTMLButtonElement, a: WaferAction, verb: string): void => {
      b.disabled = !a.enabled;
      setText(b, a.request ?? verb);
      setAttr(b, 'title', a.enabled ? `Send ${a.request}` : `${verb}: ${a.why}`);
    };
    btn(getBtn, actions.get, 'GET');
    btn(putBtn, actions.put, 'PUT');
    btn(mapBtn, actions.map, 'MAP');
    swapBtn.hidden = actions.swap === null;
    if (actions.swap) btn(swapBtn, actions.swap, 'SWAP');
    refreshBtn.disabled = !v.connected;

    let text: string;
    if (st.available === false) text = `This controller has no wafer cell (WAFERS: ${st.refusal}).`;
    else if (!v.connected) text = `Not connected: ${v.connDetail}. The map shown is the last one received.`;
    else text = actionsHint(actions);
    if (st.ignored.length > 0) text += `${text ? ' · ' : ''}ignored ${st.ignored.length} malformed map part(s), e.g. ${st.ignored[st.ignored.length - 1]}`;
    setText(hint, text);
  }

  // Controller updates come every frame while the robot moves; redraw only when what the
  // buttons depend on changed.
  let ctl = '';
  const schedule = frameThrottle(render);
  const unsubs = [
    store.onChange(() => schedule()),
    model.onChange((v) => {
      // The robot's blade B decides whether blade B, its choice and SWAP are shown.
      const k = `${v.connected}|${model.mayCommand()}|${v.connDetail}|${v.robot?.bladeB ?? ''}`;
      if (k === ctl) return;
      ctl = k;
      schedule();
    }),
    ...(stations ? [stations.onChange(() => schedule())] : []),
    ...(program ? [program.onChange((_v, stateChanged) => stateChanged && schedule())] : []),
  ];
  render();

  return {
    resize: () => undefined,
    selection: () => selection,
    dispose() {
      for (const u of unsubs) u();
      el.replaceChildren();
    },
  };
}
