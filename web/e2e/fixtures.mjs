// Fixtures of the GUI's end-to-end test:
//
// - `wrc`: a real `wrc up` (simulated boards, no SCHED_FIFO) on free ports, which starts
//   `wrc ui`; stopped after the test, and its output and the controller's events attached to
//   a failed test (and printed, so that a CI log shows them). The option `wrcState`
//   (`test.use({ wrcState: { write(dir) {…} } })`) writes files into its state directory
//   before it starts (recovery.spec.mjs: a transfer a power loss interrupted).
// - `pageErrors`: the page's uncaught errors and its requests to anywhere but `wrc ui` (which
//   are refused); a failed test also gets the page's command log.
// - `lonelyUi`: a `wrc ui` alone, its controller nowhere (the editor's compiler needs none).

import { test as base, expect } from '@playwright/test';
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import dgram from 'node:dgram';
import net from 'node:net';
import { connectSocket } from './host-client.mjs';
import { SERVE_DIR, WEB_DIR, WRC_BIN } from './settings.mjs';

export { expect };

function freeTcpPort() {
  return new Promise((res, rej) => {
    const s = net.createServer();
    s.unref();
    s.on('error', rej);
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => res(port));
    });
  });
}

function freeUdpPort() {
  return new Promise((res, rej) => {
    const s = dgram.createSocket('udp4');
    s.on('error', rej);
    s.bind(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => res(port));
    });
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** `wrc up` and what it printed; `stop` ends its whole process group. */
class Controller {
  output = '';
  /** The controller's events, from a second host connection that only listens. */
  events = '';
  url = '';
  /** The controller's host-protocol TCP port (another client beside the page). */
  hostPort = 0;
  stateDir = mkdtempSync(join(tmpdir(), 'wrc-e2e-'));
  #proc = null;
  #eventSocket = null;
  #t0 = Date.now();

  /** `realtime`: the controller's tasks at real-time priority (wrc up without --no-rt; root). */
  async start({ realtime = false } = {}) {
    if (!existsSync(WRC_BIN)) throw new Error(`no wrc binary at ${WRC_BIN} (cargo build -p wrc, or set WRC_BIN)`);
    const hostPort = await freeTcpPort();
    this.hostPort = hostPort;
    let uiPort = await freeTcpPort();
    while (uiPort === hostPort) uiPort = await freeTcpPort();
    const udpPort = await freeUdpPort();
    const args = [
      'up',
      ...(realtime ? [] : ['--no-rt']),
      '--port', `127.0.0.1:${hostPort}`,
      '--sim-addr', `127.0.0.1:${udpPort}`,
      '--ui-port', String(uiPort),
      '--state-dir', this.stateDir,
    ];
    // WRC_E2E_WEB_DIR: test that build (e.g. web/dist) instead of the one embedded in the
    // binary: `wrc up --no-ui` and a `wrc ui --web-dir` of our own, both in one process group.
    let cmd = WRC_BIN;
    let cmdArgs = args;
    if (SERVE_DIR) {
      const sock = join(this.stateDir, 'wrc.sock');
      const ui = ['ui', '--controller', sock, '--sim-addr', `127.0.0.1:${udpPort}`, '--ui-port', String(uiPort), '--web-dir', SERVE_DIR, '--programs', join(this.stateDir, 'programs')];
      cmd = '/bin/sh';
      cmdArgs = [
        '-c',
        // wrc ui retries the controller every second, so starting both at once is fine; it
        // prints `wrc ui: GUI on …` once its port is bound, which the line below waits for.
        `"$0" ${args.map((a) => `'${a}'`).join(' ')} --no-ui & "$0" ${ui.map((a) => `'${a}'`).join(' ')} & wait`,
        WRC_BIN,
      ];
    }
    console.log(`start ${SERVE_DIR ? `(with --web-dir ${SERVE_DIR}) ` : ''}${WRC_BIN} ${args.join(' ')}`);
    const proc = spawn(cmd, cmdArgs, { stdio: ['ignore', 'pipe', 'pipe'], detached: true });
    this.#proc = proc;
    proc.on('error', (e) => {
      this.output += `\n[spawn error] ${e.message}\n`;
    });
    // `wrc up` prints `wrc: GUI on …` once its GUI serves; a `wrc ui` of our own prints
    // `wrc ui: GUI on …` once its port is bound.
    const want = new RegExp(`wrc(?: ui)?: GUI on (http://127\\.0\\.0\\.1:${uiPort}\\S*)`);
    proc.stdout.on('data', (d) => {
      this.output += d.toString();
      const m = want.exec(this.output);
      if (m && !this.url) this.url = m[1];
    });
    proc.stderr.on('data', (d) => {
      this.output += d.toString();
    });
    // Resolved by the line naming the GUI (or the process ending); 30 s is only the bound.
    await new Promise((resolve, reject) => {
      const done = (err) => {
        clearTimeout(timer);
        proc.stdout.off('data', seen);
        proc.off('exit', ended);
        if (err) reject(err);
        else resolve();
      };
      const seen = () => {
        if (this.url) done();
      };
      const ended = (code, signal) =>
        done(this.url ? undefined : new Error(`wrc up exited (${code ?? signal}) before serving the GUI`));
      const timer = setTimeout(async () => {
        // The line may be missing: fall back to the HTTP port itself.
        try {
          const r = await fetch(`http://127.0.0.1:${uiPort}/`);
          if (r.ok) {
            console.warn(`WARNING: no "wrc: GUI on http://127.0.0.1:${uiPort}" line on stdout, but the port serves`);
            this.url = `http://127.0.0.1:${uiPort}/`;
            return done();
          }
        } catch {
          /* not serving */
        }
        done(new Error(`wrc up did not print "wrc: GUI on http://127.0.0.1:${uiPort}" within 30 s`));
      }, 30_000);
      proc.stdout.on('data', seen);
      proc.on('exit', ended);
      if (proc.exitCode !== null || proc.signalCode !== null) ended(proc.exitCode, proc.signalCode);
      else seen();
    });
    console.log(`GUI at ${this.url}`);
    await this.#watchEvents(hostPort);
    await this.#checkBuild();
  }

  /**
   * Listen to the controller's events on a host connection of its own. Under
   * WRC_E2E_WEB_DIR the GUI serves before the controller listens: the connection is retried
   * while refused (up to 30 s).
   */
  async #watchEvents(port) {
    const secs = () => ((Date.now() - this.#t0) / 1000).toFixed(1).padStart(6);
    let sock;
    try {
      sock = await connectSocket(port);
    } catch (e) {
      this.events += `[${secs()} s] (event connection: ${e.message})\n`;
      return;
    }
    this.#eventSocket = sock;
    sock.setEncoding('latin1');
    sock.on('data', (d) => {
      for (const line of d.split('\n')) if (line.trim()) this.events += `[${secs()} s] ${line.trim()}\n`;
    });
    sock.on('error', (e) => {
      this.events += `[${secs()} s] (event connection: ${e.message})\n`;
    });
  }

  /** Does the binary serve the app in web/dist? (It embeds web/dist at compile time.) */
  async #checkBuild() {
    let served;
    try {
      served = await (await fetch(this.url)).text();
    } catch (e) {
      throw new Error(`GET ${this.url}: ${e instanceof Error ? e.message : String(e)}`);
    }
    const index = join(WEB_DIR, 'dist', 'index.html');
    const local = existsSync(index) ? readFileSync(index, 'utf8') : null;
    if (!SERVE_DIR && local !== null && served.trim() !== local.trim()) {
      console.warn('WARNING: wrc serves another build than web/dist (rebuild wrc after npm run build to test this one)');
    }
  }

  async stop() {
    this.#eventSocket?.destroy();
    const p = this.#proc;
    this.#proc = null;
    if (p && p.exitCode === null && p.signalCode === null) {
      const exited = new Promise((r) => p.once('exit', r));
      const kill = (sig) => {
        try {
          process.kill(-p.pid, sig); // its process group: wrc up and the wrc ui it started
        } catch {
          try {
            p.kill(sig);
          } catch {
            /* gone */
          }
        }
      };
      kill('SIGTERM');
      const done = await Promise.race([exited.then(() => true), sleep(5000).then(() => false)]);
      if (!done) {
        console.warn('wrc up did not stop within 5 s of SIGTERM: SIGKILL');
        kill('SIGKILL');
        await Promise.race([exited, sleep(2000)]);
      } else {
        // wrc up stops and reaps its wrc ui before it exits (and the shell of
        // WRC_E2E_WEB_DIR waits for both), so the group is empty now; whatever is not, goes.
        kill('SIGKILL');
      }
    }
    rmSync(this.stateDir, { recursive: true, force: true });
  }
}

/** A `wrc ui` with no controller behind it (its socket names nothing): the GUI and its compiler. */
class LonelyUi {
  output = '';
  url = '';
  #proc = null;
  dir = mkdtempSync(join(tmpdir(), 'wrc-e2e-ui-'));

  async start() {
    if (!existsSync(WRC_BIN)) throw new Error(`no wrc binary at ${WRC_BIN} (cargo build -p wrc, or set WRC_BIN)`);
    const port = await freeTcpPort();
    const args = ['ui', '--controller', join(this.dir, 'no-controller.sock'), '--no-sim', '--ui-port', String(port)];
    if (SERVE_DIR) args.push('--web-dir', SERVE_DIR);
    console.log(`start ${WRC_BIN} ${args.join(' ')}`);
    const proc = spawn(WRC_BIN, args, { stdio: ['ignore', 'pipe', 'pipe'] });
    this.#proc = proc;
    const want = new RegExp(`wrc ui: GUI on (http://127\\.0\\.0\\.1:${port}\\S*)`);
    await new Promise((resolve, reject) => {
      const timer = setTimeout(() => reject(new Error(`wrc ui did not print "wrc ui: GUI on" within 30 s: ${this.output}`)), 30_000);
      proc.stdout.on('data', (d) => {
        this.output += d.toString();
        const m = want.exec(this.output);
        if (m && !this.url) {
          this.url = m[1];
          clearTimeout(timer);
          resolve();
        }
      });
      proc.stderr.on('data', (d) => {
        this.output += d.toString();
      });
      proc.on('exit', (code, signal) => {
        clearTimeout(timer);
        if (!this.url) reject(new Error(`wrc ui exited (${code ?? signal}): ${this.output}`));
      });
    });
  }

  async stop() {
    const p = this.#proc;
    this.#proc = null;
    if (p && p.exitCode === null && p.signalCode === null) {
      const exited = new Promise((r) => p.once('exit', r));
      p.kill('SIGTERM');
      if (!(await Promise.race([exited.then(() => true), sleep(5000).then(() => false)]))) p.kill('SIGKILL');
    }
    rmSync(this.dir, { recursive: true, force: true });
  }
}

/** Attach `text` to the test and print it to stderr, under `title`. */
async function report(testInfo, title, text) {
  if (!text.trim()) return;
  await testInfo.attach(title, { body: text, contentType: 'text/plain' });
  console.error(`--- ${title} ---\n${text}`);
}

const failed = (testInfo) => testInfo.status !== testInfo.expectedStatus;

export const test = base.extend({
  wrcState: [null, { option: true }],
  /** Run the controller at real-time priority (the benchmark: as `make run` does as root). */
  wrcRealtime: [false, { option: true }],

  wrc: async ({ wrcState, wrcRealtime }, use, testInfo) => {
    const wrc = new Controller();
    const tell = async () => {
      await report(testInfo, 'wrc up output (last 4000 chars)', wrc.output.slice(-4000));
      await report(testInfo, 'controller events (last 40)', wrc.events.trim().split('\n').slice(-40).join('\n'));
    };
    try {
      wrcState?.write(wrc.stateDir);
      await wrc.start({ realtime: wrcRealtime });
    } catch (e) {
      await wrc.stop();
      await tell();
      throw e;
    }
    try {
      await use(wrc);
    } finally {
      await wrc.stop();
      if (failed(testInfo)) await tell();
    }
  },

  lonelyUi: async ({}, use, testInfo) => {
    const ui = new LonelyUi();
    try {
      await ui.start();
      await use(ui);
    } finally {
      await ui.stop();
      if (failed(testInfo)) await report(testInfo, 'wrc ui output', ui.output.slice(-4000));
    }
  },

  pageErrors: async ({ page, wrc }, use, testInfo) => {
    const errors = [];
    page.on('pageerror', (e) => errors.push(e.message));
    page.on('console', (m) => {
      if (m.type() === 'error') console.log(`     browser console error: ${m.text()}`);
    });
    // Nothing may come from the network but wrc ui itself.
    const origin = new URL(wrc.url).origin;
    await page.route('**/*', (route) => {
      const u = route.request().url();
      if (u.startsWith(origin) || u.startsWith('data:') || u.startsWith('blob:')) return route.continue();
      errors.push(`request to another origin: ${u}`);
      return route.abort();
    });
    await use(errors);
    if (failed(testInfo)) {
      // What the operator would have seen.
      const log = await page
        .getByTestId('command-log')
        .innerText({ timeout: 2000 })
        .catch(() => '');
      await report(testInfo, "the page's command log (last 40 lines)", log.split('\n').slice(-40).join('\n'));
    }
  },
});

/** The Editor's New…: a new program named `name` (the Editor tab is shown). */
export async function newProgram(page, name) {
  await page.getByTestId('editor-new').click();
  await page.getByTestId('name-dialog-input').fill(name);
  await page.getByTestId('name-dialog-ok').click();
  await expect(page.getByTestId('name-dialog')).toHaveCount(0);
  await expect(page.getByTestId('editor-name')).toHaveText(name);
}
