// The E-STOP button: handled ahead of everything else on the page and never behind anything.
//
// - The press itself sends `ESTOP`: a `pointerdown` listener on the window's capture phase
//   (it runs before any other listener of the page) hands the frame to the socket before
//   anything else is done (the Commander logs it afterwards). The `click` that follows the
//   press sends nothing more; a click without a press (the keyboard's Enter or Space) sends.
// - Nothing covers it: dialogs are never modal (layer.ts) and stay below it (style.css).
// - Offline (no controller behind the page) it looks offline and says what it cannot do and
//   what to use instead: the physical E-stop. Pressed then, it says so in the status line.

import type { Commander } from '../protocol/commander';
import type { ControllerView } from '../protocol/controller-model';
import { h, setAttr, setText } from '../dom';

/** The tooltip while the page is connected. */
export const ESTOP_TITLE = 'Emergency stop: sends ESTOP the moment it is pressed (state ESTOP; RESET once the cell is safe)';
/** The tooltip and the line under the label while the page is not connected. */
export const ESTOP_OFFLINE = 'offline: use the physical E-stop';

/** A press and the click it ends in are one E-STOP [ms]. */
const CLICK_AFTER_PRESS_MS = 1500;

export interface Estop {
  el: HTMLButtonElement;
  /** Draw the connection state. */
  update(v: Pick<ControllerView, 'connected' | 'connDetail'>): void;
  dispose(): void;
}

/** The E-STOP button; `cmd.send('ESTOP')` is called at the press. */
export function mountEstop(cmd: Pick<Commander, 'send'>, now: () => number = () => performance.now()): Estop {
  const sub = h('span', { class: 'estop-sub', 'data-testid': 'estop-sub' }, '');
  const el = h(
    'button',
    { class: 'estop', 'data-testid': 'estop', 'data-offline': '0', title: ESTOP_TITLE, type: 'button' },
    h('span', { class: 'estop-label' }, 'E-STOP'),
    sub,
  );
  let pressedAt = -Infinity;
  const fire = (): void => {
    void cmd.send('ESTOP');
  };
  const onPress = (e: PointerEvent): void => {
    if (e.button !== 0 || !(e.target instanceof Node) || !el.contains(e.target)) return;
    pressedAt = now();
    fire();
  };
  const onClick = (): void => {
    if (now() - pressedAt < CLICK_AFTER_PRESS_MS) return; // the press sent it
    fire();
  };
  window.addEventListener('pointerdown', onPress, { capture: true });
  el.addEventListener('click', onClick);

  return {
    el,
    update(v) {
      const off = !v.connected;
      setAttr(el, 'data-offline', off ? '1' : '0');
      setText(sub, off ? ESTOP_OFFLINE : '');
      setAttr(
        el,
        'title',
        off
          ? `E-STOP: this page is not connected to the controller (${v.connDetail || 'offline'}), so it cannot stop the robot: use the physical E-stop.`
          : ESTOP_TITLE,
      );
    },
    dispose() {
      window.removeEventListener('pointerdown', onPress, { capture: true });
      el.removeEventListener('click', onClick);
      el.remove();
    },
  };
}
