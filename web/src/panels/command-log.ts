// The command log as the Control panel shows it: one row per entry with its time of day,
// scrolled to the newest, and a banner with the last NAK or ABS until an ACK or INF follows.

import { CommandLog, type LogEntry } from '../protocol/commander';
import { h } from '../dom';

/** `hh:mm:ss` in local time. */
function timeOfDay(d: Date): string {
  const two = (n: number): string => String(n).padStart(2, '0');
  return `${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
}

/** The log's element (banner and rows), following `log` from its entries so far on. */
export function commandLogView(log: CommandLog): HTMLElement {
  const banner = h('div', { class: 'nak-banner', 'data-testid': 'last-nak', hidden: true });
  const list = h('div', { class: 'log-list', 'data-testid': 'command-log' });

  function add(e: LogEntry): void {
    const row = h(
      'div',
      { class: `log-row log-${e.kind}` },
      h('span', { class: 'log-ts' }, timeOfDay(e.at)),
      h('span', { class: 'log-text' }, e.text),
    );
    list.append(row);
    while (list.childElementCount > CommandLog.MAX_ENTRIES) list.firstElementChild?.remove();
    list.scrollTop = list.scrollHeight;
    if (e.kind === 'nak' || e.kind === 'abs' || e.kind === 'stop') {
      banner.hidden = false;
      banner.textContent = e.text;
      banner.setAttribute('data-kind', e.kind);
    } else if (e.kind === 'ack' || e.kind === 'inf') {
      banner.hidden = true;
    }
  }

  for (const e of log.entries()) add(e);
  log.onAdd(add);
  return h('div', { class: 'command-log' }, banner, list);
}
