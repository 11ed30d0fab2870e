// The Debug pane beside the editor: the watch list (names added and removed by the operator,
// kept in this browser, read with `VARS` at every pause and about every 500 ms while the
// program runs) and, while it is paused, every variable in scope (a bare `VARS`: the running
// SUB's locals first, then the globals).

import { h } from '../dom';
import type { DebugView } from './debug-state';
import type { EditorHost } from './host';
import { parseVar, type VarValue } from './program-events';
import { WatchList } from './watch';

/** How often the watch list is read while the program runs [ms]. */
export const WATCH_PERIOD_MS = 500;

const STORE_WATCH = 'wrc.editor.watch';

function loadNames(): string[] {
  try {
    const v = JSON.parse(localStorage.getItem(STORE_WATCH) ?? '[]') as unknown;
    return Array.isArray(v) ? v.filter((x): x is string => typeof x === 'string') : [];
  } catch {
    return [];
  }
}

/** `EVT VAR` lines collected by a `VARS` request (without `EVT `). */
function varsOf(events: readonly string[]): VarValue[] {
  const out: VarValue[] = [];
  for (const e of events) {
    const m = /^VAR[ \t]+(.*)$/i.exec(e);
    const v = m ? parseVar(m[1]) : null;
    if (v) out.push(v);
  }
  return out;
}

export class DebugPane {
  readonly el: HTMLElement;
  private readonly watch = new WatchList(loadNames());
  private readonly watchBody: HTMLElement;
  private readonly varsBody: HTMLElement;
  private readonly varsNote: HTMLElement;
  private readonly input: HTMLInputElement;
  private timer: ReturnType<typeof setInterval> | null = null;
  private reading = false;
  private state: DebugView['state'] = 'none';

  constructor(private readonly host: EditorHost) {
    this.input = h('input', {
      type: 'text',
      'data-testid': 'watch-input',
      placeholder: 'variable or A[3]',
      spellcheck: 'false',
      'aria-label': 'Variable to watch',
    });
    const add = () => {
      const name = this.input.value.trim();
      if (this.watch.add(name)) {
        this.input.value = '';
        this.input.classList.remove('invalid');
        this.save();
        this.draw();
        if (this.state !== 'none') void this.readWatch();
      } else this.input.classList.add('invalid');
    };
    this.input.addEventListener('keydown', (e) => {
      if (e.key === 'Enter') add();
    });
    this.watchBody = h('tbody');
    this.varsBody = h('tbody');
    this.varsNote = h('div', { class: 'side-note', 'data-testid': 'variables-note' }, 'Shown while a program is paused.');
    this.el = h(
      'section',
      { class: 'side-section', 'data-testid': 'debug-pane' },
      h('div', { class: 'pane-title' }, 'Watch'),
      h('div', { class: 'side-row' }, this.input, h('button', { class: 'btn small', 'data-testid': 'watch-add', onclick: add }, 'Add')),
      h('table', { class: 'side-table', 'data-testid': 'watch' }, this.watchBody),
      h('div', { class: 'pane-title' }, 'Locals and globals'),
      this.varsNote,
      h('table', { class: 'side-table', 'data-testid': 'variables' }, this.varsBody),
    );
    this.draw();
  }

  /** The program's state changed: read at a pause, poll while it runs, forget at its end. */
  update(v: DebugView): void {
    this.state = v.state;
    const running = v.state === 'running' || v.state === 'stepping';
    if (running && this.timer === null) {
      this.timer = setInterval(() => void this.readWatch(), WATCH_PERIOD_MS);
    } else if (!running && this.timer !== null) {
      clearInterval(this.timer);
      this.timer = null;
    }
    if (v.state === 'paused' || v.state === 'waiting') {
      void this.readWatch();
      void this.readAll();
    } else {
      this.varsBody.replaceChildren();
      this.varsNote.textContent = v.state === 'none' ? 'Shown while a program is paused.' : 'The program runs: PAUSE to see them.';
      if (v.state === 'none') {
        this.watch.clearValues();
        this.draw();
      }
    }
  }

  /** Read the watched names (one request in flight at a time). */
  private async readWatch(): Promise<void> {
    if (this.reading || !this.host.bus.connected()) return;
    this.reading = true;
    try {
      for (const request of this.watch.requests()) {
        const { first, events } = await this.host.bus.request(request);
        if (first.kind === 'ACK') this.watch.apply(varsOf(events));
        else if (first.code === 128) this.watch.clearValues(); // no program runs (any more)
      }
    } catch {
      /* the connection went; the next pause reads again */
    } finally {
      this.reading = false;
    }
    this.draw();
  }

  /** Read every variable in scope (at a pause). */
  private async readAll(): Promise<void> {
    if (!this.host.bus.connected()) return;
    try {
      const { first, events } = await this.host.bus.request('VARS');
      if (first.kind !== 'ACK') {
        this.varsNote.textContent = `VARS: ${first.code} ${first.text}`;
        return;
      }
      const more = Number(first.fields.more ?? '0');
      this.varsNote.textContent = more > 0 ? `${more} more not listed (watch them by name).` : '';
      this.varsBody.replaceChildren(
        ...varsOf(events).map((v) =>
          h(
            'tr',
            { 'data-testid': 'variable-row', 'data-name': v.name },
            h('td', { class: 'var-name' }, v.name),
            h('td', { class: 'var-type' }, v.known ? v.type : ''),
            h('td', { class: 'var-value' }, v.known ? v.value : v.why),
          ),
        ),
      );
    } catch {
      /* the connection went */
    }
  }

  private save(): void {
    try {
      localStorage.setItem(STORE_WATCH, JSON.stringify(this.watch.names()));
    } catch {
      /* private mode: kept in memory only */
    }
  }

  private draw(): void {
    const rows = this.watch.names().map((name) => {
      const s = this.watch.value(name);
      const value = s.kind === 'value' ? s.value : s.kind === 'unknown' ? `not in scope${s.why ? ` (${s.why})` : ''}` : '—';
      return h(
        'tr',
        { 'data-testid': 'watch-row', 'data-name': name },
        h('td', { class: 'var-name' }, name),
        h('td', { class: `var-value ${s.kind}`, 'data-testid': 'watch-value', title: s.kind === 'value' ? s.type : '' }, value),
        h(
          'td',
          { class: 'var-remove' },
          h(
            'button',
            {
              class: 'btn small',
              title: `Stop watching ${name}`,
              'data-testid': 'watch-remove',
              onclick: () => {
                this.watch.remove(name);
                this.save();
                this.draw();
              },
            },
            '✕',
          ),
        ),
      );
    });
    this.watchBody.replaceChildren(...rows);
  }
}
