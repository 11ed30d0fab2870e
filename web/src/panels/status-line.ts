// The status line under the header, on every tab: the newest refusal, alarm, stop or notice
// of the `NoticeBoard` until the operator dismisses it (✕), with how many more are unread
// (click to list them all, each with its own ✕) and Dismiss all. Its height never changes, so
// nothing below it jumps; empty, it says so.

import { h, setAttr, setText } from '../dom';
import type { Notice, NoticeBoard } from '../protocol/notices';

/** `hh:mm:ss` in local time. */
function clock(ms: number): string {
  const d = new Date(ms);
  const two = (n: number): string => String(n).padStart(2, '0');
  return `${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
}

/** The status line's element. */
export function mountStatusLine(board: NoticeBoard): HTMLElement {
  const tag = h('span', { class: 'notice-tag', 'data-testid': 'status-tag' });
  const text = h('span', { class: 'notice-text', 'data-testid': 'status-text' });
  const count = h('span', { class: 'notice-count', 'data-testid': 'status-count' });
  const time = h('span', { class: 'notice-time' });
  const more = h('button', { class: 'btn small', 'data-testid': 'status-more', title: 'List every unread notice' }, '');
  const dismiss = h('button', { class: 'btn small', 'data-testid': 'status-dismiss', title: 'Dismiss this one (read)' }, '✕');
  const dismissAll = h('button', { class: 'btn small', 'data-testid': 'status-dismiss-all', title: 'Dismiss all' }, 'Dismiss all');
  const list = h('div', { class: 'notice-list', 'data-testid': 'status-list', hidden: true });
  const bar = h(
    'div',
    { class: 'notice-bar', 'data-testid': 'status-line', 'data-level': 'none', role: 'status', 'aria-live': 'polite' },
    tag,
    text,
    count,
    time,
    more,
    dismissAll,
    dismiss,
    list,
  );
  let newest: Notice | null = null;
  dismiss.addEventListener('click', () => {
    if (newest) board.dismiss(newest.id);
  });
  dismissAll.addEventListener('click', () => board.dismissAll());
  more.addEventListener('click', () => {
    list.hidden = !list.hidden;
    render(board.notices());
  });

  function row(n: Notice): HTMLElement {
    return h(
      'div',
      { class: 'notice-row', 'data-testid': 'status-item', 'data-level': n.level, 'data-tag': n.tag },
      h('span', { class: 'notice-time' }, clock(n.at)),
      h('span', { class: 'notice-tag' }, n.tag),
      h('span', { class: 'notice-text' }, n.count > 1 ? `${n.text} (×${n.count})` : n.text),
      h('button', { class: 'btn small', title: 'Dismiss', onclick: () => board.dismiss(n.id) }, '✕'),
    );
  }

  function render(all: readonly Notice[]): void {
    newest = all[0] ?? null;
    setAttr(bar, 'data-level', newest?.level ?? 'none');
    setAttr(bar, 'data-count', String(all.length));
    setText(tag, newest?.tag ?? '');
    setText(text, newest ? newest.text : 'No alarms, refusals or stops to read.');
    setAttr(text, 'title', newest?.text ?? '');
    setText(count, newest && newest.count > 1 ? `×${newest.count}` : '');
    setText(time, newest ? clock(newest.at) : '');
    more.hidden = all.length < 2;
    setText(more, list.hidden ? `+${all.length - 1} more` : 'Hide list');
    dismiss.hidden = newest === null;
    dismissAll.hidden = all.length < 2;
    if (all.length < 2) list.hidden = true;
    if (!list.hidden) list.replaceChildren(...all.map(row));
  }
  board.onChange(render);
  render(board.notices());
  return bar;
}
