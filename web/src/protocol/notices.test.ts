import { describe, expect, it } from 'vitest';
import type { FinalReply, FirstReply } from './bus';
import { COALESCE_MS, NoticeBoard, noticeForEvent, noticeForFinal, noticeForFirst } from './notices';

const nak = (code: number, text: string): FirstReply => ({ kind: 'NAK', id: 1, code, text, line: `NAK 1 ${code} ${text}` });
const ack = (fields: Record<string, string> = {}): FirstReply => ({ kind: 'ACK', id: 1, fields, line: 'ACK 1' });
const abs = (code: number, text: string): FinalReply => ({ kind: 'ABS', id: 1, code, text, line: `ABS 1 ${code} ${text}` });

describe('what the status line says of each reply and event', () => {
  it('a NAK is a refusal naming the request, code and text; 117 says it would touch the cell', () => {
    expect(noticeForFirst('MOVP 1000 0 0 0', nak(111, 'target out of reach'))).toMatchObject({
      level: 'refusal',
      tag: 'NAK 111',
      text: 'MOVP 1000 0 0 0 refused: target out of reach',
    });
    const n = noticeForFirst('MOVL 250 -150 100 0', nak(117, 'the hand would enter LP1 from the side at 42 % of the line'));
    expect(n?.text).toBe('MOVL 250 -150 100 0 refused (it would touch the cell): the hand would enter LP1 from the side at 42 % of the line');
  });

  it("a jog shortened before an obstacle and a PTP routed through the travel posture are notices; a plain ACK is nothing", () => {
    expect(noticeForFirst('JOG 1 10000', ack({ limited: 'LP1' }))).toMatchObject({ level: 'notice', text: 'JOG 1 10000: shortened to stop before LP1.' });
    expect(noticeForFirst('MOVP 250 100 20 30', ack({ route: 'travel' }))).toMatchObject({ level: 'notice', tag: 'MOVP' });
    expect(noticeForFirst('HOME', ack())).toBeNull();
  });

  it("a RESET refused while the stop still brakes (an older controller's 121) waits, it is not an error", () => {
    expect(noticeForFirst('RESET', nak(121, 'the robot is still moving; STOP and WAIT first'))).toMatchObject({ level: 'waiting', tag: 'RESET' });
  });

  it('deliberate stops (200, 201, 202) are stops, not alarms; others are alarms', () => {
    expect(noticeForFinal('MOVJ 1 2 3 4', abs(201, 'emergency stop'))).toMatchObject({ level: 'stop', tag: 'E-STOP' });
    expect(noticeForFinal('MOVJ 1 2 3 4', abs(200, 'stopped by STOP'))).toMatchObject({ level: 'stop', tag: 'STOP' });
    expect(noticeForFinal('GET LP1 3', abs(212, 'wafer not sensed'))).toMatchObject({ level: 'alarm', tag: 'ABS 212', text: 'GET LP1 3 ended: wafer not sensed' });
    expect(noticeForFinal('HOME', { kind: 'INF', id: 1, fields: {}, line: 'INF 1' })).toBeNull();
    expect(noticeForEvent('ERROR', '201 emergency stop; RESET to continue')).toMatchObject({ level: 'stop', tag: 'E-STOP' });
    expect(noticeForEvent('ERROR', '202 emergency-stop input opened')).toMatchObject({ level: 'stop', tag: 'E-STOP input' });
    expect(noticeForEvent('ERROR', '213 wafer lost from the hand while idle')).toMatchObject({ level: 'alarm', tag: 'ERROR 213', text: 'wafer lost from the hand while idle' });
  });

  it('a forced output is a notice; other events and bad lines are nothing', () => {
    expect(noticeForEvent('RECOVERY', 'forced OUT 0 0 by gui0: the hand held W4; it was dropped')).toMatchObject({
      level: 'notice',
      tag: 'FORCED',
      text: 'OUT 0 0 by gui0: the hand held W4; it was dropped',
    });
    expect(noticeForEvent('RECOVERY', 'retracted out of LP2')).toBeNull();
    expect(noticeForEvent('ERROR', 'no code')).toBeNull();
    expect(noticeForEvent('STATE', 'IDLE')).toBeNull();
  });
});

describe('NoticeBoard', () => {
  it('keeps notices newest first until dismissed; the same key within a few seconds is counted once', () => {
    let t = 0;
    const b = new NoticeBoard(() => t);
    const heard: number[] = [];
    b.onChange((l) => heard.push(l.length));
    b.add({ level: 'stop', tag: 'E-STOP', text: 'ABS', key: 'code:201' });
    t += 100;
    // The E-stop's event after the motion's ABS: one notice, counted twice.
    b.add({ level: 'stop', tag: 'E-STOP', text: 'EVT', key: 'code:201' });
    expect(b.notices()).toHaveLength(1);
    expect(b.notices()[0]).toMatchObject({ count: 2, text: 'EVT' });
    t += COALESCE_MS + 1;
    const id = b.add({ level: 'refusal', tag: 'NAK 111', text: 'x', key: 'nak:111:MOVP' });
    expect(b.notices().map((n) => n.tag)).toEqual(['NAK 111', 'E-STOP']);
    b.dismiss(id);
    expect(b.notices().map((n) => n.tag)).toEqual(['E-STOP']);
    b.dismissAll();
    expect(b.notices()).toEqual([]);
    expect(heard).toEqual([1, 1, 2, 1, 0]);
  });

  it('an alarm coalesced with a stop of the same code stays an alarm', () => {
    const b = new NoticeBoard(() => 0);
    b.add({ level: 'alarm', tag: 'ERROR 209', text: 'a', key: 'code:209' });
    b.add({ level: 'stop', tag: 'x', text: 'b', key: 'code:209' });
    expect(b.notices()[0].level).toBe('alarm');
  });

  it('replace and dismissKey take a waiting note away', () => {
    const b = new NoticeBoard(() => 0);
    const id = b.add({ level: 'waiting', tag: 'RESET', text: 'waiting', key: 'reset' });
    b.replace(id, null);
    expect(b.notices()).toEqual([]);
    b.add({ level: 'waiting', tag: 'RESET', text: 'waiting', key: 'reset' });
    b.dismissKey('reset');
    expect(b.notices()).toEqual([]);
  });

  it('keeps at most MAX notices', () => {
    const b = new NoticeBoard(() => 0);
    for (let i = 0; i < NoticeBoard.MAX + 5; i++) b.add({ level: 'refusal', tag: 't', text: `${i}`, key: `k${i}` });
    expect(b.notices()).toHaveLength(NoticeBoard.MAX);
    expect(b.notices()[0].text).toBe(`${NoticeBoard.MAX + 4}`);
  });
});
