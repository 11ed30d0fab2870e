// What feeds the status line's `NoticeBoard`: every reply to this page's requests (through the
// Commander), the alarms and forced outputs every connection hears (`EVT ERROR`, `EVT
// RECOVERY forced …`), and a RESET that waits for the arm to stand still. No DOM.

import type { Bus, Unsubscribe } from './bus';
import type { Commander } from './commander';
import { noticeForEvent, noticeForFinal, noticeForFirst, type NoticeBoard } from './notices';
import { verbOf } from './protocol';

/** Follow `bus` and `cmd` into `board`; returns the unsubscribe. */
export function feedNotices(board: NoticeBoard, bus: Pick<Bus, 'onEvent'>, cmd: Pick<Commander, 'onReply'>): Unsubscribe {
  const unsubs = [
    cmd.onReply((o) => {
      if (o.kind === 'first') {
        if (verbOf(o.request) === 'RESET' && o.reply.kind === 'ACK') board.dismissKey('reset');
        const n = noticeForFirst(o.request, o.reply);
        if (n) board.add(n);
      } else if (o.kind === 'final') {
        const n = noticeForFinal(o.request, o.reply);
        if (n) board.add(n);
      } else if (verbOf(o.request) === 'ESTOP' && !o.sent) {
        board.add({
          level: 'alarm',
          tag: 'E-STOP NOT SENT',
          text: `${o.error}. This page cannot stop the robot now: use the physical E-stop.`,
          key: 'estop-not-sent',
        });
      } else {
        board.add({ level: 'refusal', tag: verbOf(o.request) || 'request', text: `${o.request}: ${o.error}`, key: `failed:${o.request}` });
      }
    }),
    bus.onEvent((name, body) => {
      const n = noticeForEvent(name, body);
      if (n) board.add(n);
    }),
  ];
  return () => {
    for (const u of unsubs) u();
  };
}

/** How long a RESET may go unanswered before the status line says it waits [ms]. */
export const RESET_WAIT_NOTE_MS = 300;

/**
 * Send `RESET`; when its answer has not come after `RESET_WAIT_NOTE_MS` (a controller answers
 * a RESET during a stop's brake once the arm stands still), say so in the status line until
 * it comes. Resolves with the reply (null when it could not be sent).
 */
export async function sendReset(
  cmd: Pick<Commander, 'send'>,
  board: NoticeBoard,
  timers: { set: (fn: () => void, ms: number) => unknown; clear: (h: unknown) => void } = {
    set: (fn, ms) => setTimeout(fn, ms),
    clear: (h) => clearTimeout(h as ReturnType<typeof setTimeout>),
  },
): Promise<Awaited<ReturnType<Commander['send']>>> {
  let waiting: number | null = null;
  const timer = timers.set(() => {
    waiting = board.add({
      level: 'waiting',
      tag: 'RESET',
      text: 'Waiting for the arm to stand still: the stop is still braking; the controller answers the RESET then.',
      key: 'reset',
    });
  }, RESET_WAIT_NOTE_MS);
  try {
    return await cmd.send('RESET');
  } finally {
    timers.clear(timer);
    if (waiting !== null) board.replace(waiting, null);
  }
}
