// Sending the operator's requests: the `Commander` sends each request, tells the controller
// model its reply, and writes the request, its ACK/NAK and its INF/ABS to the `CommandLog`
// that the Control panel shows. Shared by the header (E-STOP, control lock, RESET), the Control
// panel, the Trace card and the Wafers panel. No DOM.
//
// A request is handed to the socket before anything else is done for it (the log, the
// listeners): the E-STOP's frame leaves the page first. Every reply is also told to the
// `onReply` listeners (the status line's notices).

import type { Bus, FinalReply, FirstReply, Unsubscribe } from './bus';
import type { ControllerModel } from './controller-model';
import { Listeners } from './listeners';
import { STOP_CODES } from './notices';
import { replyRest, verbOf } from './protocol';

/**
 * What a log entry is: a request sent, a first reply, a final reply (`stop`: an ABS of a stop
 * someone asked for, 200-202, not a fault), or a note.
 */
export type LogKind = 'out' | 'ack' | 'nak' | 'inf' | 'abs' | 'stop' | 'info';

/** One line of the command log. */
export interface LogEntry {
  kind: LogKind;
  text: string;
  /** When it was added (the log shows the local time of day). */
  at: Date;
}

/** The command log: the newest `CommandLog.MAX_ENTRIES` entries, oldest first. */
export class CommandLog {
  /** Entries kept; older ones are dropped. */
  static readonly MAX_ENTRIES = 300;
  private readonly list: LogEntry[] = [];
  private readonly listeners = new Listeners<[LogEntry]>('command log');

  add(kind: LogKind, text: string): void {
    const entry: LogEntry = { kind, text, at: new Date() };
    this.list.push(entry);
    if (this.list.length > CommandLog.MAX_ENTRIES) this.list.splice(0, this.list.length - CommandLog.MAX_ENTRIES);
    this.listeners.emit(entry);
  }

  entries(): readonly LogEntry[] {
    return this.list;
  }

  /** Called with every entry added from now on. */
  onAdd(cb: (e: LogEntry) => void): Unsubscribe {
    return this.listeners.add(cb);
  }
}

/** A request that was sent: its first reply, and its final one when the verb completes later. */
export interface Sent {
  first: FirstReply;
  final: Promise<FinalReply> | null;
}

/** What became of a request, as the `onReply` listeners hear it. */
export type Outcome =
  | { kind: 'first'; request: string; reply: FirstReply }
  | { kind: 'final'; request: string; reply: FinalReply }
  /** Not sent (not connected), or no reply came (the connection went, a timeout). */
  | { kind: 'failed'; request: string; error: string; sent: boolean };

/** Sends requests, logging each with its replies. */
export class Commander {
  readonly log = new CommandLog();
  private readonly outcomes = new Listeners<[Outcome]>('command outcome');
  constructor(
    private readonly bus: Bus,
    private readonly model: ControllerModel,
  ) {}

  /** Called with each request's first reply, its final reply, or its failure. */
  onReply(cb: (o: Outcome) => void): Unsubscribe {
    return this.outcomes.add(cb);
  }

  /** Send one request; resolves with its first reply (null when it could not be sent). */
  async send(line: string): Promise<Sent | null> {
    // The frame goes to the socket within this call (the bus writes it synchronously); only
    // then is it logged.
    const pending = this.bus.request(line);
    const connected = this.bus.connected();
    this.log.add('out', `> ${line}`);
    let r: Awaited<ReturnType<Bus['request']>>;
    try {
      r = await pending;
    } catch (e) {
      const error = e instanceof Error ? e.message : String(e);
      this.log.add('nak', `${line}: ${error}`);
      this.outcomes.emit({ kind: 'failed', request: line, error, sent: connected });
      return null;
    }
    const { first, final } = r;
    this.model.noteReply(line, first);
    this.outcomes.emit({ kind: 'first', request: line, reply: first });
    const verb = verbOf(line);
    if (first.kind === 'ACK') {
      const fields = Object.entries(first.fields).map(([k, v]) => `${k}=${v}`).join(' ');
      this.log.add('ack', `ACK ${verb}${fields ? ` ${fields}` : ''}${final ? ' (started)' : ''}`);
    } else {
      this.log.add('nak', `NAK ${verb}: ${first.code} ${first.text}`);
    }
    if (final) {
      final
        .then((f) => {
          this.outcomes.emit({ kind: 'final', request: line, reply: f });
          if (f.kind === 'INF') {
            // GET/PUT say which wafer moved (`INF 3 W3`), MAP the slots it found (`INF 7 LP1 1111…`).
            const rest = replyRest(f.line);
            this.log.add('inf', `INF ${verb} finished${rest ? `: ${rest}` : ''}`);
          } else this.log.add(STOP_CODES.has(f.code) ? 'stop' : 'abs', `ABS ${verb}: ${f.code} ${f.text}`);
        })
        .catch((e: unknown) => {
          const error = e instanceof Error ? e.message : String(e);
          this.log.add('abs', `${verb}: ${error}`);
          this.outcomes.emit({ kind: 'failed', request: line, error, sent: true });
        });
    }
    if (verb === 'OUT' && first.kind === 'ACK') this.model.refresh();
    return { first, final };
  }
}
