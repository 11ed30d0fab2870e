// A running program's ALARM (`EVT ALARM`) in the header, whichever tab is open: code, program,
// place and text in red until the operator dismisses it (the program itself goes on). The
// Editor's console logs every alarm as well.

import type { Bus } from '../protocol/bus';
import { h } from '../dom';
import { parseAlarm } from '../editor/program-events';
import './alarm-banner.css';


/** The banner element (hidden until an alarm comes). */
export function mountAlarmBanner(bus: Bus): HTMLElement {
  const text = h('span', { class: 'alarm-text', 'data-testid': 'alarm-text' });
  const banner = h(
    'div',
    { class: 'alarm-banner', 'data-testid': 'alarm', role: 'alert', hidden: true },
    text,
    h('button', { 'data-testid': 'alarm-dismiss', title: 'Dismiss', onclick: () => (banner.hidden = true) }, '✕'),
  );
  bus.onEvent((name, body) => {
    if (name !== 'ALARM') return;
    const a = parseAlarm(body);
    if (!a) return;
    const where = a.at ? ` ${a.at.file}:${a.at.line}` : '';
    text.textContent = `ALARM ${a.code}${a.program ? ` ${a.program}` : ''}${where}: ${a.text}`;
    banner.title = text.textContent;
    banner.hidden = false;
  });
  return banner;
}
