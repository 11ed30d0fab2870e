import { describe, expect, it } from 'vitest';
import type { FirstReply } from './bus';
import type { Outcome } from './commander';
import { NoticeBoard } from './notices';
import { RESET_WAIT_NOTE_MS, feedNotices, sendReset } from './notice-feed';

/** Timers run by hand. */
function timers() {
  const queue: { fn: () => void; at: number }[] = [];
  let now = 0;
  return {
    set: (fn: () => void, ms: number) => {
      const t = { fn, at: now + ms };
      queue.push(t);
      return t;
    },
    clear: (h: unknown) => {
      const i = queue.indexOf(h as { fn: () => void; at: number });
      if (i >= 0) queue.splice(i, 1);
    },
    advance(ms: number) {
      now += ms;
      for (const t of [...queue]) if (t.at <= now) {
        queue.splice(queue.indexOf(t), 1);
        t.fn();
      }
    },
  };
}

const ackReset: FirstReply = { kind: 'ACK', id: 4, fields: {}, line: 'ACK 4' };

describe('sendReset', () => {
  it('says "waiting for the arm to stand still" while the controller has not answered, then takes it away', async () => {
    const b = new NoticeBoard(() => 0);
    const t = timers();
    let answer: (v: { first: FirstReply; final: null }) => void = () => undefined;
    const sent = sendReset({ send: () => new Promise((r) => (answer = r)) }, b, t);
    t.advance(RESET_WAIT_NOTE_MS - 1);
    expect(b.notices()).toEqual([]);
    t.advance(1);
    expect(b.notices()[0]).toMatchObject({ level: 'waiting', tag: 'RESET' });
    expect(b.notices()[0].text).toContain('Waiting for the arm to stand still');
    answer({ first: ackReset, final: null });
    await sent;
    expect(b.notices()).toEqual([]);
  });

  it('an answer that comes at once shows nothing', async () => {
    const b = new NoticeBoard(() => 0);
    const t = timers();
    await sendReset({ send: async () => ({ first: ackReset, final: null }) }, b, t);
    t.advance(RESET_WAIT_NOTE_MS * 2);
    expect(b.notices()).toEqual([]);
  });
});

describe('feedNotices', () => {
  function wire() {
    const b = new NoticeBoard(() => 0);
    let reply: (o: Outcome) => void = () => undefined;
    let event: (n: string, body: string, line: string) => void = () => undefined;
    feedNotices(b, { onEvent: (cb) => ((event = cb), () => undefined) }, { onReply: (cb) => ((reply = cb), () => undefined) });
    return { b, reply: (o: Outcome) => reply(o), event: (n: string, body: string) => event(n, body, `EVT ${n} ${body}`) };
  }

  it('an E-STOP that could not be sent tells the operator to use the physical E-stop', () => {
    const w = wire();
    w.reply({ kind: 'failed', request: 'ESTOP', error: 'not connected (wrc ui not reachable)', sent: false });
    expect(w.b.notices()[0]).toMatchObject({ level: 'alarm', tag: 'E-STOP NOT SENT' });
    expect(w.b.notices()[0].text).toContain('use the physical E-stop');
  });

  it('replies and events become notices; an accepted RESET clears a waiting one', () => {
    const w = wire();
    w.reply({ kind: 'first', request: 'RESET', reply: { kind: 'NAK', id: 1, code: 121, text: 'still moving', line: '' } });
    expect(w.b.notices()[0].level).toBe('waiting');
    w.reply({ kind: 'first', request: 'RESET', reply: ackReset });
    expect(w.b.notices()).toEqual([]);
    w.event('ERROR', '203 following error on axis j2');
    w.reply({ kind: 'final', request: 'MOVJ 1 2 3 4', reply: { kind: 'ABS', id: 2, code: 203, text: 'following error', line: '' } });
    expect(w.b.notices()).toHaveLength(1);
    expect(w.b.notices()[0]).toMatchObject({ level: 'alarm', count: 2 });
  });
});
