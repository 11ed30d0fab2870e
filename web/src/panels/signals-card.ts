// The Control panel's Signals card: the inputs as lamps and the outputs as switches, named
// from the configuration (`EVT SIGNAL` lines of the `ROBOT` reply: `vacuum valve`, `E-stop
// button`) with guarded outputs marked; the unnamed ones as numbered grids (all of them, from
// a controller that names none). Switching a guarded output asks first, naming the output and
// what the wafer map says it will do (`the hand holds W4: it will drop`), and then sends it
// with FORCE when the map says a blade holds a wafer (the controller refuses it otherwise,
// NAK 141).

import type { RobotInfo, SignalInfo } from '../protocol/bus';
import type { Commander } from '../protocol/commander';
import type { ControllerView } from '../protocol/controller-model';
import type { WaferMap } from '../cell/wafers';
import { h, setAttr } from '../dom';
import { confirmAction, type ConfirmOptions } from './confirm-dialog';

/** What switching a guarded output means now, for its confirmation. */
export function guardedSwitch(
  s: Pick<SignalInfo, 'n' | 'name'>,
  on: boolean,
  map: Pick<WaferMap, 'hand' | 'handB' | 'handUncertain' | 'handBUncertain'> | null,
): ConfirmOptions & { request: string } {
  const held: string[] = [];
  if (map?.hand) held.push(`the hand holds ${map.hand}${map.handUncertain ? '?' : ''}`);
  if (map?.handB) held.push(`blade B holds ${map.handB}${map.handBUncertain ? '?' : ''}`);
  const verb = on ? 'on' : 'off';
  const what = `output ${s.n} (${s.name})`;
  const loaded = held.length > 0;
  const effect = loaded
    ? on
      ? `The wafer map says ${held.join(' and ')}: switching a guarded output changes what holds it.`
      : `The wafer map says ${held.join(' and ')}: it will no longer be held and may drop.`
    : 'The wafer map says no blade holds a wafer; the controller checks again.';
  return {
    title: `Switch ${verb} ${what}?`,
    text: `${what[0].toUpperCase()}${what.slice(1)} is guarded. ${effect}${loaded ? ' The controller logs it as forced, with this page as its source.' : ''}`,
    request: `OUT ${s.n} ${on ? 1 : 0}${loaded ? ' FORCE' : ''}`,
    ok: `Switch ${verb}${loaded ? ' (force)' : ''}`,
    danger: loaded,
  };
}

export interface SignalsCard {
  el: HTMLElement;
  /** The robot's signals changed (a `ROBOT` reply). */
  build(robot: RobotInfo | null): void;
  /** Draw the words and whether outputs may be switched (`why`: '' when they may). */
  update(v: Pick<ControllerView, 'inputs' | 'outputs'>, why: string): void;
}

export function signalsCard(cmd: Pick<Commander, 'send'>, map: () => WaferMap | null): SignalsCard {
  const named = h('div', { class: 'signals-named', 'data-testid': 'signals-named' });
  const inputsGrid = h('div', { class: 'io-grid', 'data-testid': 'inputs' });
  const outputsGrid = h('div', { class: 'io-grid', 'data-testid': 'outputs' });
  const inTitle = h('div', { class: 'io-title' }, 'Inputs');
  const outTitle = h('div', { class: 'io-title' }, 'Outputs');
  const el = h('section', { class: 'card' }, h('h3', {}, 'Signals'), named, inTitle, inputsGrid, outTitle, outputsGrid);
  let lamps = new Map<number, HTMLElement>();
  let switches = new Map<number, HTMLButtonElement>();
  let key = '';

  async function toggle(n: number, sig: SignalInfo | undefined, sw: HTMLButtonElement): Promise<void> {
    const on = sw.getAttribute('data-on') !== '1';
    if (!sig?.guarded) {
      void cmd.send(`OUT ${n} ${on ? 1 : 0}`);
      return;
    }
    const ask = guardedSwitch(sig, on, map());
    if (await confirmAction(ask)) void cmd.send(ask.request);
  }

  function build(robot: RobotInfo | null): void {
    const nIn = robot?.inputs ?? 32;
    const nOut = robot?.outputs ?? 32;
    const sigs = robot?.signals ?? [];
    const k = `${nIn}/${nOut}/${sigs.map((s) => `${s.dir}${s.n}${s.guarded ? 'g' : ''}${s.name}`).join('|')}`;
    if (k === key) return;
    key = k;
    lamps = new Map();
    switches = new Map();
    named.replaceChildren();
    inputsGrid.replaceChildren();
    outputsGrid.replaceChildren();
    const byKey = new Map(sigs.map((s) => [`${s.dir}${s.n}`, s]));
    for (const s of sigs) {
      if (s.dir === 'in' && s.n < nIn) {
        const lamp = h('span', { class: 'lamp', 'data-testid': `input-${s.n}`, 'data-on': '0', 'data-name': s.name, title: `input ${s.n}: ${s.name}` }, String(s.n));
        lamps.set(s.n, lamp);
        named.append(h('div', { class: 'signal-row', 'data-testid': `signal-in-${s.n}` }, lamp, h('span', { class: 'signal-name' }, s.name)));
      } else if (s.dir === 'out' && s.n < nOut) {
        const sw = outputSwitch(s.n, s);
        named.append(
          h(
            'div',
            { class: 'signal-row', 'data-testid': `signal-out-${s.n}` },
            sw,
            h('span', { class: 'signal-name' }, s.name),
            s.guarded ? h('span', { class: 'signal-guarded', title: 'Guarded: switching it asks first (a blade may hold a wafer)' }, 'guarded') : null,
          ),
        );
      }
    }
    for (let i = 0; i < nIn; i++) {
      if (lamps.has(i)) continue;
      const lamp = h('span', { class: 'lamp', 'data-testid': `input-${i}`, 'data-on': '0', title: `input ${i}` }, String(i));
      lamps.set(i, lamp);
      inputsGrid.append(lamp);
    }
    for (let i = 0; i < nOut; i++) if (!byKey.has(`out${i}`)) outputsGrid.append(outputSwitch(i, undefined));
    const hasNamed = sigs.length > 0;
    named.hidden = !hasNamed;
    inTitle.textContent = hasNamed ? 'Other inputs' : 'Inputs';
    outTitle.textContent = hasNamed ? 'Other outputs' : 'Outputs';
  }

  function outputSwitch(n: number, sig: SignalInfo | undefined): HTMLButtonElement {
    const sw = h(
      'button',
      {
        class: 'switch',
        'data-testid': `output-${n}`,
        'data-on': '0',
        'data-guarded': sig?.guarded ? '1' : '0',
        'data-name': sig?.name,
        role: 'switch',
        'aria-checked': 'false',
        title: sig ? `output ${n}: ${sig.name}${sig.guarded ? ' (guarded)' : ''}` : `output ${n}`,
      },
      String(n),
    );
    sw.addEventListener('click', () => void toggle(n, sig, sw));
    switches.set(n, sw);
    return sw;
  }

  return {
    el,
    build,
    update(v, why) {
      for (const [i, l] of lamps) setAttr(l, 'data-on', v.inputs !== null && (v.inputs >>> i) & 1 ? '1' : '0');
      for (const [i, s] of switches) {
        const on = v.outputs !== null && (v.outputs >>> i) & 1 ? '1' : '0';
        setAttr(s, 'data-on', on);
        setAttr(s, 'aria-checked', on === '1' ? 'true' : 'false');
        s.disabled = why !== '';
        const name = s.getAttribute('data-name');
        const base = name ? `output ${i}: ${name}${s.getAttribute('data-guarded') === '1' ? ' (guarded)' : ''}` : `output ${i}`;
        setAttr(s, 'title', why ? `${base} — ${why}` : base);
      }
    },
  };
}
