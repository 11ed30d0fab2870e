// The other tabs of this browser on the same GUI: each tab is a command source of its own
// (`gui0`, `gui1`, …), and a tab learns its own name only from its CONTROL reply. A tab that
// knows its name tells the others (a BroadcastChannel of the page's origin), so that a tab
// can say "another tab of this browser (gui0)" rather than a bare `gui0`. No DOM.

import type { Unsubscribe } from './bus';
import { Listeners } from './listeners';

/** What the channel carries. */
type Message = { type: 'hello'; tab: string } | { type: 'source'; tab: string; source: string | null } | { type: 'bye'; tab: string };

/** The part of a BroadcastChannel this uses (a fake in tests). */
export interface ChannelLike {
  postMessage(m: unknown): void;
  onmessage: ((ev: { data: unknown }) => void) | null;
  close(): void;
}

/** The sources other tabs of this browser have told. */
export class TabPeers {
  private readonly peers = new Map<string, string>();
  private readonly listeners = new Listeners<[]>('tabs');
  private mine: string | null = null;
  private readonly channel: ChannelLike | null;

  constructor(
    channel: ChannelLike | null = typeof BroadcastChannel === 'function' ? (new BroadcastChannel('wrc-tabs') as unknown as ChannelLike) : null,
    private readonly tab: string = Math.random().toString(36).slice(2),
  ) {
    this.channel = channel;
    if (!channel) return;
    channel.onmessage = (ev) => this.receive(ev.data);
    channel.postMessage({ type: 'hello', tab } satisfies Message);
  }

  /** This tab's source name (null: not known, or gone with the connection). */
  announce(source: string | null): void {
    if (source === this.mine) return;
    this.mine = source;
    this.channel?.postMessage({ type: 'source', tab: this.tab, source } satisfies Message);
  }

  /** Whether `source` is another tab of this browser. */
  isPeer(source: string): boolean {
    for (const s of this.peers.values()) if (s === source) return true;
    return false;
  }

  onChange(cb: () => void): Unsubscribe {
    return this.listeners.add(cb);
  }

  close(): void {
    this.channel?.postMessage({ type: 'bye', tab: this.tab } satisfies Message);
    this.channel?.close();
  }

  private receive(data: unknown): void {
    const m = data as Partial<Message> | null;
    if (!m || typeof m.tab !== 'string' || m.tab === this.tab) return;
    if (m.type === 'hello') {
      if (this.mine !== null) this.channel?.postMessage({ type: 'source', tab: this.tab, source: this.mine } satisfies Message);
      return;
    }
    const before = this.peers.get(m.tab);
    if (m.type === 'source' && typeof (m as { source?: unknown }).source === 'string') this.peers.set(m.tab, (m as { source: string }).source);
    else this.peers.delete(m.tab);
    if (this.peers.get(m.tab) !== before) this.listeners.emit();
  }
}

/**
 * Who holds control, as the header says it: `nobody`, `gui0 (this page)`, `another tab of
 * this browser (gui0)`, `tcp3`.
 */
export function ownerText(owner: string, me: string | null, isPeer: (s: string) => boolean): string {
  if (owner === 'none' || owner === '') return 'nobody';
  if (me !== null && owner === me) return `${owner} (this page)`;
  if (isPeer(owner)) return `another tab of this browser (${owner})`;
  return owner;
}
