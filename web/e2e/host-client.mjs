// The one host-protocol client of the browser tests and the GUI benchmark: another client of
// the controller's TCP port beside the page (docs/protocol.md), which takes control, sends
// requests with ids and waits for their replies, or only listens to the events.
//
// - `connectHost(port)` retries a refused connection until its deadline: under
//   `WRC_E2E_WEB_DIR` the GUI may serve before the controller listens.
// - `send(request)` resolves with the request's first reply line (`ACK …` or `NAK …`);
//   `job(request)` also gives a promise of its final one (`INF …` or `ABS …`) when it was
//   accepted. Every other line (events, replies to nobody here) goes to `onLine` listeners.

import net from 'node:net';

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** A TCP socket to the controller's host port, retried while refused, up to `deadlineMs`. */
export async function connectSocket(port, deadlineMs = 30_000) {
  const until = Date.now() + deadlineMs;
  for (;;) {
    try {
      return await new Promise((resolve, reject) => {
        const s = net.connect(port, '127.0.0.1');
        s.once('connect', () => {
          s.off('error', reject);
          resolve(s);
        });
        s.once('error', reject);
      });
    } catch (e) {
      if (e?.code !== 'ECONNREFUSED' || Date.now() > until) throw e;
      await sleep(100);
    }
  }
}

/** A host client on `port` (see the module doc). */
export async function connectHost(port, deadlineMs = 30_000) {
  const sock = await connectSocket(port, deadlineMs);
  sock.setEncoding('latin1');
  let buf = '';
  let next = 0;
  /** First replies awaited, by id. */
  const firsts = new Map();
  /** Final replies awaited, by id. */
  const finals = new Map();
  const listeners = new Set();
  let closedWith = null;
  const fail = (why) => {
    closedWith = why;
    for (const w of [...firsts.values(), ...finals.values()]) w.reject(new Error(why));
    firsts.clear();
    finals.clear();
  };
  sock.on('error', (e) => fail(`host connection: ${e.message}`));
  sock.on('close', () => fail('host connection closed'));
  sock.on('data', (d) => {
    buf += d;
    let nl;
    while ((nl = buf.indexOf('\n')) >= 0) {
      const line = buf.slice(0, nl).trim();
      buf = buf.slice(nl + 1);
      if (!line) continue;
      const m = /^(ACK|NAK|INF|ABS) (\d+)(?:\s|$)/.exec(line);
      const id = m ? Number(m[2]) : null;
      if (m && (m[1] === 'ACK' || m[1] === 'NAK') && firsts.has(id)) {
        const w = firsts.get(id);
        firsts.delete(id);
        w.resolve(line);
        continue;
      }
      if (m && (m[1] === 'INF' || m[1] === 'ABS') && finals.has(id)) {
        const w = finals.get(id);
        finals.delete(id);
        w.resolve(line);
        continue;
      }
      for (const cb of listeners) cb(line);
    }
  });

  /** Send `request` with a new id; `wantsFinal` registers for its INF/ABS too. */
  function request(request, wantsFinal) {
    if (closedWith) return Promise.reject(new Error(closedWith));
    const id = ++next;
    const first = new Promise((resolve, reject) => firsts.set(id, { resolve, reject }));
    const final = wantsFinal ? new Promise((resolve, reject) => finals.set(id, { resolve, reject })) : null;
    final?.catch(() => undefined);
    sock.write(`${id} ${request}\n`);
    return { id, first, final };
  }

  return {
    /** The first reply line of `request`. */
    send: (req) => request(req, false).first,
    /**
     * `{ first, final }` of an action (`GET LP1 1`, `HOME`): `final` resolves with its INF or
     * ABS line, or with the NAK when it was refused.
     */
    async job(req) {
      const r = request(req, true);
      const first = await r.first;
      if (first.startsWith('NAK')) return { first, final: Promise.resolve(first) };
      return { first, final: r.final };
    },
    /** Every line that answers nothing sent here (events). */
    onLine(cb) {
      listeners.add(cb);
      return () => listeners.delete(cb);
    },
    close: () => sock.destroy(),
  };
}
