// "Are you sure?" for a deliberate action (a guarded output, discarding the editor's edits):
// a dialog that says what will happen and names the request, with the action's own button
// and Cancel (Escape cancels). Shown with `showLayer`, so the E-STOP stays pressable.

import { h } from '../dom';
import { showLayer } from './layer';

export interface ConfirmOptions {
  title: string;
  /** What will happen, in sentences. */
  text: string;
  /** The request it sends, shown as code (none: nothing is sent, e.g. discarding edits). */
  request?: string;
  /** The confirming button's text (`Switch off`, `Discard`). */
  ok: string;
  /** A dangerous action: its button is drawn as a warning. */
  danger?: boolean;
}

/** Ask; resolves true when the operator confirmed, false on Cancel or Escape. */
export function confirmAction(o: ConfirmOptions): Promise<boolean> {
  return new Promise((resolve) => {
    const ok = h('button', { class: `btn ${o.danger ? 'warn' : 'primary'}`, 'data-testid': 'confirm-ok' }, o.ok);
    const cancel = h('button', { class: 'btn', 'data-testid': 'confirm-cancel' }, 'Cancel');
    const dialog = h(
      'dialog',
      { class: 'confirm-dialog', 'data-testid': 'confirm-dialog', 'aria-label': o.title },
      h('h3', { 'data-testid': 'confirm-title' }, o.title),
      h('p', { 'data-testid': 'confirm-text' }, o.text),
      o.request ? h('p', {}, 'Sends ', h('code', { 'data-testid': 'confirm-request' }, o.request)) : null,
      h('div', { class: 'dialog-buttons' }, cancel, ok),
    );
    let hide = (): void => undefined;
    const done = (answer: boolean): void => {
      hide();
      dialog.remove();
      resolve(answer);
    };
    ok.addEventListener('click', () => done(true));
    cancel.addEventListener('click', () => done(false));
    hide = showLayer(dialog, () => done(false));
    cancel.focus();
  });
}

export interface AskNameOptions {
  title: string;
  /** What the name is for. */
  text: string;
  /** The confirming button's text (`Save`, `Create`). */
  ok: string;
  /** The name filled in at first. */
  initial?: string;
  /** Why a name cannot be used ('' when it can). */
  check: (name: string) => string;
}

/** Ask for a name; resolves with it (trimmed), or null on Cancel or Escape. */
export function askName(o: AskNameOptions): Promise<string | null> {
  return new Promise((resolve) => {
    const input = h('input', {
      type: 'text',
      class: 'name',
      'data-testid': 'name-dialog-input',
      'aria-label': o.title,
      maxlength: '32',
      spellcheck: 'false',
      autocomplete: 'off',
      value: o.initial ?? '',
    });
    const why = h('p', { class: 'dialog-why', 'data-testid': 'name-dialog-error', role: 'alert' });
    const ok = h('button', { class: 'btn primary', 'data-testid': 'name-dialog-ok' }, o.ok);
    const cancel = h('button', { class: 'btn', 'data-testid': 'name-dialog-cancel' }, 'Cancel');
    const dialog = h(
      'dialog',
      { class: 'confirm-dialog', 'data-testid': 'name-dialog', 'aria-label': o.title },
      h('h3', {}, o.title),
      h('p', {}, o.text),
      input,
      why,
      h('div', { class: 'dialog-buttons' }, cancel, ok),
    );
    let hide = (): void => undefined;
    const done = (answer: string | null): void => {
      hide();
      dialog.remove();
      resolve(answer);
    };
    const submit = (): void => {
      const name = input.value.trim();
      const bad = o.check(name);
      why.textContent = bad;
      if (!bad) done(name);
    };
    ok.addEventListener('click', submit);
    cancel.addEventListener('click', () => done(null));
    input.addEventListener('keydown', (e) => {
      if (e.key === 'Enter') submit();
    });
    input.addEventListener('input', () => (why.textContent = ''));
    hide = showLayer(dialog, () => done(null));
    input.focus();
    input.select();
  });
}
