// The Control panel's Trace card: **Save trace** sends `TRACE SAVE [<name>]` (docs/trace.md)
// and shows where the controller wrote the file, or its NAK. The request and its reply also
// appear in the command log, like every request of the panel.

import type { Commander } from '../protocol/commander';
import type { ControllerModel } from '../protocol/controller-model';
import { traceSaveOutcome, traceSaveRequest } from '../protocol/protocol';
import { h } from '../dom';

export const TRACE_SAVE_TITLE =
  "TRACE SAVE: write the controller's last seconds of samples and every request and reply to a .wrctrace file";

/** The Trace card, for `mountControl`'s extra cards. */
export function traceSaveCard(model: ControllerModel, cmd: Commander): HTMLElement {
  const name = h('input', {
    type: 'text',
    class: 'name',
    'data-testid': 'trace-name',
    'aria-label': 'Trace name (optional)',
    placeholder: 'name (optional)',
    spellcheck: 'false',
    autocomplete: 'off',
    maxlength: 32,
  });
  const result = h('div', { class: 'trace-saved', 'data-testid': 'trace-saved', 'data-state': '', 'aria-live': 'polite' });
  let busy = false;
  const button = h(
    'button',
    { class: 'btn', 'data-testid': 'trace-save', title: TRACE_SAVE_TITLE, onclick: () => void save() },
    'Save trace',
  );

  /** `saved` names the file (on the controller's computer); `refused` says why not. */
  function show(state: 'saving' | 'saved' | 'refused', text: string, file = ''): void {
    result.textContent = text;
    result.setAttribute('data-state', state);
    result.setAttribute('data-file', file);
    result.title =
      state === 'saved' ? 'On the controller’s computer: open it with “Open trace…” in the Simulator tab to scrub through it' : '';
  }

  async function save(): Promise<void> {
    let line: string;
    try {
      line = traceSaveRequest(name.value);
    } catch (e) {
      show('refused', e instanceof Error ? e.message : String(e));
      return;
    }
    busy = true;
    button.disabled = true;
    show('saving', 'saving…');
    try {
      const sent = await cmd.send(line);
      if (sent === null) {
        show('refused', 'TRACE SAVE could not be sent (see the command log)');
        return;
      }
      const out = traceSaveOutcome(sent.first);
      if (!out.ok) {
        show('refused', `not saved: ${out.text}`);
        return;
      }
      const s = out.saved;
      const counts = [
        s.samples === null ? null : `${s.samples} samples`,
        s.messages === null ? null : `${s.messages} messages`,
        s.seconds === null ? null : `${s.seconds} s`,
      ].filter((x) => x !== null);
      show('saved', `saved ${s.file}${counts.length > 0 ? ` (${counts.join(', ')})` : ''}`, s.file);
    } finally {
      busy = false;
      button.disabled = !model.v.connected;
    }
  }

  model.onChange((v) => {
    button.disabled = busy || !v.connected;
  });

  return h(
    'section',
    { class: 'card trace-card' },
    h('h3', {}, 'Trace'),
    h('div', { class: 'trace-save-row' }, name, button),
    result,
  );
}
