// Dialogs over the page that never hide or disable the E-STOP. A modal `<dialog>`
// (`showModal`) makes everything else inert, the E-STOP included; these are shown non-modal
// (`show()`) above a backdrop that dims and blocks the page below the header's E-STOP,
// which stays above both (style.css: `.estop` over `.layer-backdrop` and `.layer-dialog`).
// Escape closes the top one.

import { h } from '../dom';

/** The dialogs shown now, the top one last. */
const stack: { dialog: HTMLDialogElement; onEscape: () => void }[] = [];
let backdrop: HTMLElement | null = null;

function onKey(e: KeyboardEvent): void {
  if (e.key !== 'Escape' || stack.length === 0) return;
  e.preventDefault();
  stack[stack.length - 1].onEscape();
}

/**
 * Show `dialog` above the page (appended to the body if it is not in the document) until the
 * returned function is called; `onEscape` runs when Escape is pressed while it is the top one
 * (it should close it). Never modal: the E-STOP stays pressable.
 */
export function showLayer(dialog: HTMLDialogElement, onEscape: () => void): () => void {
  if (!dialog.isConnected) document.body.append(dialog);
  if (!backdrop) backdrop = h('div', { class: 'layer-backdrop', 'data-testid': 'layer-backdrop' });
  if (!backdrop.isConnected) document.body.append(backdrop);
  backdrop.hidden = false;
  dialog.classList.add('layer-dialog');
  if (stack.length === 0) document.addEventListener('keydown', onKey, true);
  const entry = { dialog, onEscape };
  stack.push(entry);
  if (typeof dialog.show === 'function') dialog.show();
  else dialog.setAttribute('open', '');
  let shown = true;
  return () => {
    if (!shown) return;
    shown = false;
    const i = stack.indexOf(entry);
    if (i >= 0) stack.splice(i, 1);
    if (dialog.open && typeof dialog.close === 'function') dialog.close();
    else dialog.removeAttribute('open');
    if (stack.length === 0) {
      document.removeEventListener('keydown', onKey, true);
      if (backdrop) backdrop.hidden = true;
    }
  };
}

/** Whether any layer is shown (for tests and the console). */
export function layerShown(): boolean {
  return stack.length > 0;
}
