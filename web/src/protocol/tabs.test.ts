import { describe, expect, it } from 'vitest';
import { TabPeers, ownerText, type ChannelLike } from './tabs';

/** Channels of one origin: a message posted on one reaches the others. */
function hub() {
  const all: ChannelLike[] = [];
  return () => {
    const c: ChannelLike = {
      onmessage: null,
      postMessage(m) {
        for (const o of all) if (o !== c) o.onmessage?.({ data: structuredClone(m) });
      },
      close() {
        all.splice(all.indexOf(c), 1);
      },
    };
    all.push(c);
    return c;
  };
}

describe('TabPeers', () => {
  it('a tab that holds control is named "another tab of this browser" in the other', () => {
    const channel = hub();
    const a = new TabPeers(channel(), 'a');
    const b = new TabPeers(channel(), 'b');
    let changes = 0;
    b.onChange(() => changes++);
    a.announce('gui0');
    expect(b.isPeer('gui0')).toBe(true);
    expect(ownerText('gui0', null, (s) => b.isPeer(s))).toBe('another tab of this browser (gui0)');
    expect(ownerText('gui0', 'gui0', (s) => a.isPeer(s))).toBe('gui0 (this page)');
    a.announce(null); // released
    expect(b.isPeer('gui0')).toBe(false);
    expect(changes).toBe(2);
  });

  it('a tab opened later learns the others that already told their name; a closed tab is forgotten', () => {
    const channel = hub();
    const a = new TabPeers(channel(), 'a');
    a.announce('gui3');
    const late = new TabPeers(channel(), 'late');
    expect(late.isPeer('gui3')).toBe(true);
    a.close();
    expect(late.isPeer('gui3')).toBe(false);
  });

  it('ignores what it cannot read, and works without a channel', () => {
    const c = hub()();
    const t = new TabPeers(c, 'x');
    c.onmessage?.({ data: null });
    c.onmessage?.({ data: { type: 'source', tab: 'y', source: 42 } });
    expect(t.isPeer('42')).toBe(false);
    const alone = new TabPeers(null, 'z');
    alone.announce('gui0');
    expect(ownerText('tcp3', 'gui0', (s) => alone.isPeer(s))).toBe('tcp3');
    expect(ownerText('none', null, () => false)).toBe('nobody');
  });
});
