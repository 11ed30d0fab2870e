// @vitest-environment happy-dom
import { afterEach, describe, expect, it } from 'vitest';
import { ESTOP_OFFLINE, mountEstop } from './estop';
import { confirmAction, askName } from './confirm-dialog';
import { layerShown, showLayer } from './layer';
import { h } from '../dom';

/** A Commander that records what it was asked to send, in order. */
function recorder() {
  const sent: string[] = [];
  return { sent, cmd: { send: async (line: string) => (sent.push(line), null) } };
}

function press(el: Element): void {
  el.dispatchEvent(new PointerEvent('pointerdown', { bubbles: true, button: 0 }));
}

afterEach(() => {
  // Whatever a test left open is closed the operator's way.
  for (let i = 0; i < 10 && layerShown(); i++) document.dispatchEvent(new KeyboardEvent('keydown', { key: 'Escape' }));
  document.body.replaceChildren();
});

describe('the E-STOP', () => {
  it('sends ESTOP at the press, before the click, and the click does not send it again', () => {
    const r = recorder();
    const e = mountEstop(r.cmd);
    document.body.append(e.el);
    press(e.el.firstElementChild!); // its label: the press lands on a child
    expect(r.sent).toEqual(['ESTOP']);
    e.el.click();
    expect(r.sent).toEqual(['ESTOP']);
    e.dispose();
  });

  it("the keyboard's Enter or Space (a click without a press) sends it", () => {
    let t = 0;
    const r = recorder();
    const e = mountEstop(r.cmd, () => t);
    document.body.append(e.el);
    e.el.click();
    expect(r.sent).toEqual(['ESTOP']);
    press(e.el);
    t += 5000; // a later click without its own press
    e.el.click();
    expect(r.sent).toEqual(['ESTOP', 'ESTOP', 'ESTOP']);
    e.dispose();
  });

  it('offline it looks offline and says to use the physical E-stop, yet stays pressable', () => {
    const r = recorder();
    const e = mountEstop(r.cmd);
    document.body.append(e.el);
    e.update({ connected: false, connDetail: 'wrc ui not reachable' });
    expect(e.el.getAttribute('data-offline')).toBe('1');
    expect(e.el.textContent).toContain(ESTOP_OFFLINE);
    expect(e.el.title).toContain('use the physical E-stop');
    expect(e.el.disabled).toBe(false);
    e.update({ connected: true, connDetail: '' });
    expect(e.el.getAttribute('data-offline')).toBe('0');
    expect(e.el.textContent).toBe('E-STOP');
    e.dispose();
  });
});

describe('E-STOP while each kind of dialog is open', () => {
  /** The page's E-STOP, and a way to see that nothing makes it inert or disabled. */
  function page() {
    const r = recorder();
    const e = mountEstop(r.cmd);
    const header = h('header', { class: 'app-header' }, e.el);
    document.body.append(header);
    const free = (): boolean => !e.el.disabled && !e.el.closest('[inert]') && !document.querySelector('dialog:modal');
    return { r, e, free };
  }

  const dialogs: [string, () => Promise<unknown>][] = [
    ['a confirmation (a guarded output, discarding edits)', () => confirmAction({ title: 'Switch off output 0 (vacuum valve)?', text: 'W4 will drop', ok: 'Switch off' })],
    ['a name (New…, Save as…)', () => askName({ title: 'Save as…', text: 'name', ok: 'Save', check: () => '' })],
    [
    'a layer of its own (the recovery panel’s dialog)',
    async () => {
      const hide = showLayer(h('dialog', {}, 'RETRACT?'), () => hide());
    },
  ],
  ];

  for (const [what, open] of dialogs) {
    it(`${what}: it is shown, never modal, and pressing E-STOP sends ESTOP`, async () => {
      const p = page();
      void open();
      await Promise.resolve();
      expect(layerShown()).toBe(true);
      const dialog = document.querySelector('dialog');
      expect(dialog?.open).toBe(true);
      expect(p.free()).toBe(true);
      press(p.e.el);
      expect(p.r.sent).toEqual(['ESTOP']);
      p.e.dispose();
    });
  }

  it('Escape closes the top dialog (answering Cancel), and the backdrop goes with the last one', async () => {
    const answer = confirmAction({ title: 't', text: 'x', ok: 'OK' });
    document.dispatchEvent(new KeyboardEvent('keydown', { key: 'Escape' }));
    expect(await answer).toBe(false);
    expect(layerShown()).toBe(false);
    expect(document.querySelector('dialog')).toBeNull();
  });

  it('a confirmation resolves true with its own button', async () => {
    const answer = confirmAction({ title: 't', text: 'x', ok: 'Switch off', request: 'OUT 0 0 FORCE' });
    expect(document.querySelector('[data-testid="confirm-request"]')?.textContent).toBe('OUT 0 0 FORCE');
    (document.querySelector('[data-testid="confirm-ok"]') as HTMLButtonElement).click();
    expect(await answer).toBe(true);
  });

  it('a name is checked before it is taken', async () => {
    const answer = askName({ title: 'New', text: 'x', ok: 'Create', check: (n) => (/^[a-z_]+$/.test(n) ? '' : 'bad name') });
    const input = document.querySelector('[data-testid="name-dialog-input"]') as HTMLInputElement;
    const ok = document.querySelector('[data-testid="name-dialog-ok"]') as HTMLButtonElement;
    input.value = 'no spaces';
    ok.click();
    expect(document.querySelector('[data-testid="name-dialog-error"]')?.textContent).toBe('bad name');
    input.value = ' wafer_cycle ';
    ok.click();
    expect(await answer).toBe('wafer_cycle');
  });
});
