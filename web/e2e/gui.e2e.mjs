#!/usr/bin/env node
// End-to-end test of the web GUI in real headless Chromium against a real `wrc up`
// (simulated boards, no SCHED_FIFO) that starts `wrc ui`.
//
//   npm run e2e                       (from web/; builds nothing: run `npm run build` and
//                                      `cargo build -p wrc` first, the binary embeds web/dist)
//   WRC_BIN=/path/to/wrc              the binary (default: ../target/debug/wrc from web/)
//   WRC_TEST_OUTPUT=/dir              screenshots (default: <repo>/test-output/gui/)
//   WRC_CHROMIUM=/usr/bin/chromium    the browser (never downloaded)
//   WRC_E2E_HEADFUL=1                 show the browser (needs a display)
//   WRC_E2E_WEB_DIR=dist              serve this build (`wrc up --no-ui` + `wrc ui --web-dir`)
//                                      instead of the one embedded in the binary
//
// Exit code 0 when every step passed; 1 with a message naming the failed step otherwise.

import { spawn } from 'node:child_process';
import { mkdtempSync, mkdirSync, rmSync, existsSync, readFileSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import net from 'node:net';
import dgram from 'node:dgram';
import { chromium } from 'playwright-core';
import { encodeTrace } from './trace-fixture.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const webDir = resolve(here, '..');
const repo = resolve(webDir, '..');
const wrcBin = resolve(webDir, process.env.WRC_BIN ?? '../target/debug/wrc');
const outDir = resolve(process.env.WRC_TEST_OUTPUT ?? join(repo, 'test-output', 'gui'));
const chromiumPath = process.env.WRC_CHROMIUM ?? '/usr/bin/chromium';
const STEP_MS = Number(process.env.WRC_E2E_STEP_MS ?? 30_000);
const TOTAL_MS = Number(process.env.WRC_E2E_TOTAL_MS ?? 480_000);

const t0 = Date.now();
const secs = () => ((Date.now() - t0) / 1000).toFixed(1).padStart(6);
const log = (msg) => console.log(`[${secs()} s] ${msg}`);

// ---------------------------------------------------------------------------------------------
// helpers

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

function withTimeout(promise, ms, what) {
  let timer;
  return Promise.race([
    promise.finally(() => clearTimeout(timer)),
    new Promise((_, rej) => {
      timer = setTimeout(() => rej(new Error(`timed out after ${ms / 1000} s: ${what}`)), ms);
    }),
  ]);
}

let stepNo = 0;
const results = [];
// A step makes several waits of up to STEP_MS each; on a loaded 2-core machine the browser
// alone can take seconds per click, so a step as a whole gets twice that.
async function step(name, fn, ms = 2 * STEP_MS) {
  stepNo += 1;
  const label = `${String(stepNo).padStart(2)}. ${name}`;
  const start = Date.now();
  try {
    await withTimeout(Promise.resolve().then(fn), ms, name);
  } catch (e) {
    results.push({ label, ok: false, ms: Date.now() - start });
    const err = new Error(`step "${name}" failed: ${e instanceof Error ? e.message : String(e)}`);
    err.step = label;
    throw err;
  }
  results.push({ label, ok: true, ms: Date.now() - start });
  log(`ok   ${label} (${((Date.now() - start) / 1000).toFixed(1)} s)`);
}

// ---------------------------------------------------------------------------------------------
// the controller

let wrc = null;
let wrcOut = '';
let pageLog = '';
let stateDir = null;

async function startWrc() {
  if (!existsSync(wrcBin)) throw new Error(`no wrc binary at ${wrcBin} (cargo build -p wrc, or set WRC_BIN)`);
  const hostPort = await freeTcpPort();
  let uiPort = await freeTcpPort();
  while (uiPort === hostPort) uiPort = await freeTcpPort();
  const udpPort = await freeUdpPort();
  stateDir = mkdtempSync(join(tmpdir(), 'wrc-e2e-'));
  const args = [
    'up',
    '--no-rt',
    '--port', `127.0.0.1:${hostPort}`,
    '--sim-addr', `127.0.0.1:${udpPort}`,
    '--ui-port', String(uiPort),
    '--state-dir', stateDir,
  ];
  // WRC_E2E_WEB_DIR: test that build (e.g. web/dist) instead of the one embedded in the binary:
  // `wrc up --no-ui` and a `wrc ui --web-dir` of our own, both in one process group.
  const webDirOverride = process.env.WRC_E2E_WEB_DIR ? resolve(webDir, process.env.WRC_E2E_WEB_DIR) : null;
  let cmd = wrcBin;
  let cmdArgs = args;
  if (webDirOverride) {
    const sock = join(stateDir, 'wrc.sock');
    const ui = [
      'ui', '--controller', sock, '--sim-addr', `127.0.0.1:${udpPort}`, '--ui-port', String(uiPort), '--web-dir', webDirOverride,
    ];
    cmd = '/bin/sh';
    cmdArgs = [
      '-c',
      // wrc ui retries the controller every second, so starting both at once is fine; it does
      // not print the line `wrc up` prints, so print it when the port serves.
      `"$0" ${args.map((a) => `'${a}'`).join(' ')} --no-ui & "$0" ${ui.map((a) => `'${a}'`).join(' ')} & ` +
        `until curl -sf -o /dev/null http://127.0.0.1:${uiPort}/; do sleep 0.2; done; echo "wrc: GUI on http://127.0.0.1:${uiPort}"; wait`,
      wrcBin,
    ];
  }
  log(`start ${cmd === wrcBin ? '' : `(with --web-dir ${webDirOverride}) `}${wrcBin} ${args.join(' ')}`);
  wrc = spawn(cmd, cmdArgs, { stdio: ['ignore', 'pipe', 'pipe'], detached: true });
  wrc.on('error', (e) => {
    wrcOut += `\n[spawn error] ${e.message}\n`;
  });
  const want = new RegExp(`wrc: GUI on (http://127\\.0\\.0\\.1:${uiPort}\\S*)`);
  let url = null;
  const onData = (d) => {
    wrcOut += d.toString();
    const m = want.exec(wrcOut);
    if (m && !url) url = m[1];
  };
  wrc.stdout.on('data', onData);
  wrc.stderr.on('data', (d) => {
    wrcOut += d.toString();
  });
  const deadline = Date.now() + 30_000;
  while (!url) {
    if (wrc.exitCode !== null || wrc.signalCode !== null) {
      throw new Error(`wrc up exited (${wrc.exitCode ?? wrc.signalCode}) before serving the GUI`);
    }
    if (Date.now() > deadline) {
      // The line may be missing: fall back to the HTTP port itself.
      try {
        const r = await fetch(`http://127.0.0.1:${uiPort}/`);
        if (r.ok) {
          log(`WARNING: no "wrc: GUI on http://127.0.0.1:${uiPort}" line on stdout, but the port serves`);
          url = `http://127.0.0.1:${uiPort}/`;
          break;
        }
      } catch {
        /* not yet */
      }
      throw new Error(`wrc up did not print "wrc: GUI on http://127.0.0.1:${uiPort}" within 30 s`);
    }
    await sleep(100);
  }
  log(`GUI at ${url}`);
  watchEvents(hostPort);
  return url;
}

/** A second host connection that only listens: the controller's events, for a failure report. */
let events = '';
let eventSocket = null;
function watchEvents(port) {
  const sock = net.connect(port, '127.0.0.1');
  eventSocket = sock;
  sock.setEncoding('latin1');
  sock.on('data', (d) => {
    for (const line of d.split('\n')) if (line.trim()) events += `[${secs()} s] ${line.trim()}\n`;
  });
  sock.on('error', (e) => {
    events += `[${secs()} s] (event connection: ${e.message})\n`;
  });
}

async function stopWrc() {
  eventSocket?.destroy();
  if (!wrc) return;
  const p = wrc;
  wrc = null;
  if (p.exitCode !== null || p.signalCode !== null) return;
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
    log('wrc up did not stop within 5 s of SIGTERM: SIGKILL');
    kill('SIGKILL');
    await Promise.race([exited, sleep(2000)]);
  } else {
    // wrc ui may outlive wrc up for a moment; make sure nothing of the group is left.
    await sleep(200);
    try {
      process.kill(-p.pid, 0);
      kill('SIGKILL');
    } catch {
      /* the group is gone */
    }
  }
}

// ---------------------------------------------------------------------------------------------
// page helpers

const tid = (id) => `[data-testid="${id}"]`;

async function num(page, id) {
  const t = (await page.locator(tid(id)).textContent()) ?? '';
  return Number(t.trim());
}

function angleDiff(a, b) {
  let d = (((a - b) % 360) + 540) % 360 - 180;
  if (d === -180) d = 180;
  return Math.abs(d);
}

/** Wait until Current shows the pose (within 0.01) and the robot stands (IDLE). */
async function waitPose(page, x, y, z, yaw) {
  let last = '';
  for (;;) {
    const cur = {
      x: await num(page, 'current-x'),
      y: await num(page, 'current-y'),
      z: await num(page, 'current-z'),
      yaw: await num(page, 'current-yaw'),
    };
    const state = await page.locator(tid('state')).getAttribute('data-state');
    last = `x=${cur.x} y=${cur.y} z=${cur.z} yaw=${cur.yaw} state=${state}`;
    if (
      Math.abs(cur.x - x) <= 0.01 &&
      Math.abs(cur.y - y) <= 0.01 &&
      Math.abs(cur.z - z) <= 0.01 &&
      angleDiff(cur.yaw, yaw) <= 0.01 &&
      state === 'IDLE'
    ) {
      return cur;
    }
    const nak = page.locator(tid('last-nak'));
    if (await nak.isVisible()) throw new Error(`refused: ${await nak.textContent()} (at ${last})`);
    await sleep(100);
  }
}

async function setDestination(page, mode, values) {
  await page.click(tid(`mode-${mode}`));
  for (const [k, v] of Object.entries(values)) await page.fill(tid(`dest-${k}`), String(v));
}

async function setEditorText(page, text) {
  const content = page.locator('#panel-editor .cm-content');
  await content.click();
  await page.keyboard.press('Control+A');
  await page.keyboard.press('Delete');
  await page.keyboard.insertText(text);
  const got = await page.evaluate(() => {
    const lines = [...document.querySelectorAll('#panel-editor .cm-line')].map((l) => l.textContent ?? '');
    return lines.join('\n');
  });
  if (got.trim() !== text.trim()) throw new Error(`the editor holds ${JSON.stringify(got)}, not the program`);
}

/** The joint values the 3D view draws now (the simulator's read-back of its scene). */
async function drawnPose(page) {
  const p = await page.evaluate(() => window.wrc?.sim?.drawnPose() ?? null);
  if (!p) throw new Error('the 3D view draws no robot (no WebGL, or ROBOT not answered)');
  return p;
}

/** Move the trace scrubber to sample `i` as a drag would (an input event). */
async function scrubTo(page, i) {
  await page.locator(tid('trace-scrubber')).evaluate((el, v) => {
    el.value = String(v);
    el.dispatchEvent(new Event('input', { bubbles: true }));
  }, i);
}

/**
 * A 3 s trace of the default robot at 10 ms: standing at home until 1 s, then J1 from -75° to
 * 45° and Z up 50 mm until 2 s (MOVING), input 2 on from 1.5 s; MOVJ, its ACK and its INF.
 */
function fixtureTrace() {
  const t0 = 5_000_000_000;
  const samples = [];
  for (let k = 0; k < 300; k++) {
    const f = Math.min(1, Math.max(0, (k - 100) / 100));
    const pulses = [Math.round((-75 + 120 * f) * 1000), 150_000, -75_000, Math.round(50 * f * 1000)];
    samples.push({
      tNs: t0 + k * 10_000_000,
      commanded: pulses,
      actual: pulses,
      inputs: (k >= 150 ? 1 << 2 : 0) | (1 << 14),
      outputs: 1 << 3,
      state: k >= 100 && k < 200 ? 1 : 0,
    });
  }
  const messages = [
    { tNs: t0 + 1_000_000_000, direction: 'request', source: 0, client: 1, line: '5 MOVJ 45 150 -75 50' },
    { tNs: t0 + 1_001_000_000, direction: 'reply', source: 0, client: 1, line: 'ACK 5' },
    { tNs: t0 + 2_000_000_000, direction: 'reply', source: 0, client: 1, line: 'INF 5' },
  ];
  return encodeTrace({
    meta: {
      reason: 'e2e fixture',
      axisNames: ['j1', 'j2', 'j3', 'z'],
      configToml: readFileSync(join(repo, 'config', 'default.toml'), 'utf8'),
      savedAtNs: t0 + 3_000_000_000,
    },
    samples,
    messages,
  });
}

async function shot(page, selector, file) {
  const path = join(outDir, file);
  if (selector) await page.locator(selector).screenshot({ path });
  else await page.screenshot({ path, fullPage: true });
  log(`     screenshot ${path}`);
}

// ---------------------------------------------------------------------------------------------
// the test

const BAD_PROGRAM = `' e2e test program: TOTAL is never assigned
SPEED 100
MOVEP POSE(260, 40, 10, 0)
PRINT "e2e total", TOTAL
`;
const GOOD_PROGRAM = `' e2e test program
SPEED 100
TOTAL = 1 + 2
MOVEP POSE(260, 40, 10, 0)
PRINT "e2e total", TOTAL
`;

const FAULT_PROGRAM = `' e2e test program: division by zero at run time
X = 1
X = X - 1
PRINT 1 / X
`;

async function run() {
  mkdirSync(outDir, { recursive: true });
  const url = await startWrc();

  // Does the binary serve the app in web/dist? (It embeds web/dist at compile time.)
  try {
    const served = await (await fetch(url)).text();
    const local = existsSync(join(webDir, 'dist', 'index.html')) ? readFileSync(join(webDir, 'dist', 'index.html'), 'utf8') : null;
    if (!process.env.WRC_E2E_WEB_DIR && local !== null && served.trim() !== local.trim()) {
      log('WARNING: wrc serves another build than web/dist (rebuild wrc after npm run build to test this one)');
    }
  } catch (e) {
    throw new Error(`GET ${url}: ${e instanceof Error ? e.message : String(e)}`);
  }

  const browser = await chromium.launch({
    executablePath: chromiumPath,
    headless: !process.env.WRC_E2E_HEADFUL,
    args: [
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
    ],
  });
  const pageErrors = [];
  let page = null;
  try {
    const context = await browser.newContext({ viewport: { width: 1600, height: 1000 } });
    page = await context.newPage();
    page.on('pageerror', (e) => pageErrors.push(e.message));
    page.on('console', (m) => {
      if (m.type() === 'error') log(`     browser console error: ${m.text()}`);
    });
    // Nothing may come from the network but wrc ui itself.
    const origin = new URL(url).origin;
    await page.route('**/*', (route) => {
      const u = route.request().url();
      if (u.startsWith(origin) || u.startsWith('data:') || u.startsWith('blob:')) return route.continue();
      pageErrors.push(`request to another origin: ${u}`);
      return route.abort();
    });

    await step('open the page and connect', async () => {
      await page.goto(url);
      await page.waitForSelector(`${tid('connection')}[data-connected="1"]`, { timeout: STEP_MS });
      await page.waitForSelector(tid('current-axis-1'), { timeout: STEP_MS }); // ROBOT answered
      await page.waitForSelector('#panel-control', { timeout: STEP_MS });
      for (const id of ['panel-simulator', 'panel-wafers', 'panel-editor', 'panel-plots']) {
        if ((await page.locator(`#${id}`).count()) !== 1) throw new Error(`no #${id}`);
      }
      if (!(await page.locator('#panel-simulator').isVisible())) throw new Error('the Simulator tab is not shown first');
    });

    await step('take control', async () => {
      await page.click(tid('take-control'));
      await page.waitForSelector(`${tid('lock-owner')}[data-mine="1"]`, { timeout: STEP_MS });
    });

    await step('HOME: state IDLE and homed', async () => {
      await page.click(tid('home'));
      await page.waitForFunction(
        () => document.querySelector('[data-testid="command-log"]')?.textContent?.includes('INF HOME'),
        null,
        { timeout: STEP_MS },
      );
      await page.waitForSelector(`${tid('state')}[data-state="IDLE"]`, { timeout: STEP_MS });
      await page.waitForSelector(`${tid('homed')}[data-homed="1"]`, { timeout: STEP_MS });
    });

    await step('PTP from the Destination panel: MOVP 250 100 20 30', async () => {
      await setDestination(page, 'ptp', { x: 250, y: 100, z: 20, yaw: 30 });
      await page.click(tid('go'));
      await waitPose(page, 250, 100, 20, 30);
    });

    await step('Straight move: MOVL 300 -50 20 0', async () => {
      await setDestination(page, 'line', { x: 300, y: -50, z: 20, yaw: 0 });
      await page.click(tid('go'));
      await waitPose(page, 300, -50, 20, 0);
    });

    await step('a NAK is shown: MOVP out of reach', async () => {
      await setDestination(page, 'ptp', { x: 1000, y: 0, z: 0, yaw: 0 });
      await page.click(tid('go'));
      await page.waitForSelector(`${tid('last-nak')}:has-text("111")`, { timeout: STEP_MS });
    });

    await step('toggle output 3 on', async () => {
      await page.click(tid('output-3'));
      await page.waitForSelector(`${tid('output-3')}[data-on="1"]`, { timeout: STEP_MS });
    });

    await step('screenshots: control and simulator', async () => {
      await sleep(500); // let the 3D view draw the last pose
      await shot(page, '#panel-control', 'control.png');
      await shot(page, '#panel-simulator', 'simulator.png');
    });

    await step('Trace viewer: a corrupt file is refused with a sentence', async () => {
      const bad = fixtureTrace();
      bad[40] ^= 0x10; // inside the meta section
      const path = join(stateDir, 'corrupt.wrctrace');
      writeFileSync(path, bad);
      await page.click(tid('tab-simulator'));
      await page.setInputFiles(tid('trace-open'), path);
      await page.waitForSelector(`${tid('trace-error')}:has-text("corrupt.wrctrace is corrupt: its meta section fails its CRC-32 check")`, {
        timeout: STEP_MS,
      });
      if ((await page.locator(tid('trace-bar')).getAttribute('data-open')) !== '0') throw new Error('a corrupt trace was opened');
    });

    await step('Trace viewer: scrub a trace, the 3D view follows it; Close returns to live', async () => {
      const path = join(stateDir, 'fixture.wrctrace');
      writeFileSync(path, fixtureTrace());
      await page.setInputFiles(tid('trace-open'), path);
      await page.waitForSelector(`${tid('trace-bar')}[data-open="1"]`, { timeout: STEP_MS });
      const error = (await page.locator(tid('trace-error')).textContent()) ?? '';
      if (error) throw new Error(`the trace was refused: ${error}`);
      const note = (await page.locator(tid('trace-note')).textContent()) ?? '';
      if (note) throw new Error(`the trace is not drawn with its own robot: ${note}`);
      await page.waitForSelector(`${tid('trace-state')}[data-state="IDLE"]`, { timeout: STEP_MS });
      const start = await drawnPose(page);
      if (Math.abs(start.j1 - -75) > 0.01 || Math.abs(start.z) > 0.01) throw new Error(`sample 0 is drawn at ${JSON.stringify(start)}`);

      await scrubTo(page, 150);
      await page.waitForSelector(`${tid('trace-state')}[data-state="MOVING"]`, { timeout: STEP_MS });
      const time = (await page.locator(tid('trace-time')).textContent()) ?? '';
      if (!time.startsWith('1.500 s / 2.990 s')) throw new Error(`the time readout says ${JSON.stringify(time)}`);
      const inputs = (await page.locator(tid('trace-inputs')).textContent()) ?? '';
      if (inputs !== '0x00004004') throw new Error(`the inputs read ${inputs}, not 0x00004004`);
      const current = page.locator(`${tid('trace-message')}[data-current="1"]`);
      if ((await current.count()) !== 1) throw new Error('no message is highlighted at 1.5 s');
      const currentText = (await current.textContent()) ?? '';
      if (!currentText.includes('ACK 5')) throw new Error(`the highlighted message is ${JSON.stringify(currentText)}, not ACK 5`);
      const listed = await page.locator(tid('trace-message')).count();
      if (listed !== 3) throw new Error(`${listed} messages are listed within ±1 s of 1.5 s, not 3`);
      // Half-way: J1 at -15°, Z at 25 mm.
      const mid = await drawnPose(page);
      if (Math.abs(mid.j1 - -15) > 0.01 || Math.abs(mid.z - 25) > 0.01) {
        throw new Error(`the 3D view draws ${JSON.stringify(mid)} at 1.5 s, not j1 -15 and z 25`);
      }
      // The pose is in the scene; two animation frames later it is on the canvas.
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      await shot(page, '#panel-simulator', 'trace-viewer.png');

      // Play runs on from the scrubber in the trace's time and stops at its end (1.5 s later;
      // a click can take longer than that on a loaded machine, so the end is not raced).
      await page.click(tid('trace-play'));
      await page.waitForSelector(`${tid('trace-play')}[data-playing="0"]`, { timeout: STEP_MS });
      const last = await page.locator(tid('trace-scrubber')).inputValue();
      if (last !== '299') throw new Error(`playing stopped at sample ${last}, not at the last (299)`);
      const played = await drawnPose(page);
      if (Math.abs(played.j1 - 45) > 0.01 || Math.abs(played.z - 50) > 0.01) {
        throw new Error(`the 3D view draws ${JSON.stringify(played)} at the end, not j1 45 and z 50`);
      }
      await page.waitForSelector(`${tid('trace-state')}[data-state="IDLE"]`, { timeout: STEP_MS });

      await page.click(tid('trace-close'));
      await page.waitForSelector(`${tid('trace-bar')}[data-open="0"]`, { timeout: STEP_MS });
      // Live again: the drawn J1 is the controller's (the Control panel's current position).
      await page.waitForFunction(
        () => {
          const live = Number(document.querySelector('[data-testid="current-axis-1"]')?.textContent ?? NaN);
          const drawn = window.wrc?.sim?.drawnPose();
          return drawn && Math.abs(drawn.j1 - live) < 0.01;
        },
        null,
        { timeout: STEP_MS },
      );
    });

    await step('Editor: compile a program with an error, see it inline and in the problems', async () => {
      await page.click(tid('tab-editor'));
      await page.waitForSelector('#panel-editor .cm-content', { state: 'visible', timeout: STEP_MS });
      await page.fill(tid('editor-name'), 'e2e_demo');
      await setEditorText(page, BAD_PROGRAM);
      await page.click(tid('editor-compile'));
      await page.waitForSelector(`${tid('problem')}:has-text("TOTAL")`, { timeout: STEP_MS });
      const problem = (await page.locator(tid('problem')).first().textContent()) ?? '';
      if (!/4:20/.test(problem)) throw new Error(`the problem is not at 4:20: ${problem}`);
      // The inline mark is on line 4, under TOTAL.
      const mark = page.locator('#panel-editor .cm-line').nth(3).locator('.cm-lintRange-error');
      await mark.first().waitFor({ timeout: STEP_MS });
      const marked = (await mark.first().textContent()) ?? '';
      if (!marked.includes('TOTAL')) throw new Error(`the lint range covers ${JSON.stringify(marked)}, not TOTAL`);
      const status = (await page.locator(tid('editor-status')).textContent()) ?? '';
      if (!/1 error/.test(status)) throw new Error(`status says ${JSON.stringify(status)}`);
      await shot(page, '#panel-editor', 'editor-error.png');
    });

    await step('Editor: fix it, compile, run to INF and see PRINT in the console', async () => {
      await setEditorText(page, GOOD_PROGRAM);
      await page.click(tid('editor-compile'));
      await page.waitForSelector(`${tid('editor-status')}:has-text("compiled")`, { timeout: STEP_MS });
      if ((await page.locator('#panel-editor .cm-lintRange-error').count()) !== 0) throw new Error('the error mark stayed');
      await page.click(tid('editor-run'));
      await page.waitForSelector(`${tid('console')}:has-text("e2e total 3")`, { timeout: STEP_MS });
      await page.waitForSelector(`${tid('console')}:has-text("INF program e2e_demo ended")`, { timeout: STEP_MS });
      await page.waitForSelector(`${tid('state')}[data-state="IDLE"]`, { timeout: STEP_MS });
      await shot(page, '#panel-editor', 'editor.png');
    });

    await step('Editor: a run-time error ends with ABS and marks its line', async () => {
      await page.fill(tid('editor-name'), 'e2e_fault');
      await setEditorText(page, FAULT_PROGRAM);
      await page.click(tid('editor-run')); // uploads first: the text is new
      await page.waitForSelector(`${tid('console')}:has-text("ABS 210")`, { timeout: STEP_MS });
      const text = (await page.locator(tid('console')).textContent()) ?? '';
      if (!/e2e_fault line 4/.test(text)) throw new Error(`the ABS does not name line 4: ${text}`);
      const marked = page.locator('#panel-editor .cm-line.cm-abs-line');
      await marked.first().waitFor({ timeout: STEP_MS });
      const lineText = (await marked.first().textContent()) ?? '';
      if (!lineText.includes('1 / X')) throw new Error(`the marked line is ${JSON.stringify(lineText)}`);
    });

    await step('Plots tab', async () => {
      await page.click(tid('tab-plots'));
      await page.waitForSelector('#panel-plots', { state: 'visible', timeout: STEP_MS });
      await sleep(1500); // a few timing updates
      await shot(page, '#panel-plots', 'plots.png');
    });

    await step('Wafers tab: a column per station, a fresh map is all unmapped', async () => {
      await page.click(tid('tab-wafers'));
      await page.waitForSelector('#panel-wafers', { state: 'visible', timeout: STEP_MS });
      await page.waitForSelector(tid('wafer-station-LP1'), { timeout: STEP_MS }); // WAFERS answered
      const slots = page.locator(`${tid('wafer-station-LP1')} [data-testid^="wafer-slot-LP1-"]`);
      const n = await slots.count();
      if (n !== 25) throw new Error(`LP1 shows ${n} slots, not 25`);
      const states = await slots.evaluateAll((els) => els.map((e) => e.getAttribute('data-state')));
      const other = states.filter((s) => s !== 'unknown');
      if (other.length > 0) throw new Error(`a fresh map shows ${JSON.stringify(other)}, not only "unknown"`);
      // Slot 25 on top, like a cassette.
      const first = await slots.first().getAttribute('data-testid');
      if (first !== 'wafer-slot-LP1-25') throw new Error(`the top slot is ${first}, not wafer-slot-LP1-25`);
      const hand = await page.locator(tid('wafer-hand')).getAttribute('data-wafer');
      if (hand !== '') throw new Error(`the hand shows ${JSON.stringify(hand)} on a fresh map`);
      // Selecting an unmapped slot: GET stays disabled (nothing is sent), MAP is offered.
      await page.click(tid('wafer-slot-LP1-3'));
      await page.waitForSelector(`${tid('wafer-slot-LP1-3')}[data-selected="1"]`, { timeout: STEP_MS });
      if (!(await page.locator(tid('wafer-get')).isDisabled())) throw new Error('GET is enabled for an unmapped slot');
      if (!(await page.locator(tid('wafer-map')).isEnabled())) throw new Error('MAP is disabled while this page holds control');
      await shot(page, '#panel-wafers', 'wafers.png');
    });

    await step('HOLD during a long move, RESUME to its target', async () => {
      await page.click(tid('tab-simulator'));
      // The speed slider sends SPEED when released.
      await page.locator(tid('speed-slider')).evaluate((el) => {
        el.value = '20';
        el.dispatchEvent(new Event('input', { bubbles: true }));
        el.dispatchEvent(new Event('change', { bubbles: true }));
      });
      await page.waitForSelector(`${tid('current-speed')}:has-text("20 %")`, { timeout: STEP_MS });
      const logText = async () => (await page.locator(tid('command-log')).textContent()) ?? '';
      const count = (text, re) => (text.match(re) ?? []).length;
      const before = await logText();
      const endsBefore = count(before, /INF MOVJ|ABS MOVJ/g);
      const absBefore = count(before, /ABS MOVJ/g);
      if (!(await page.locator(tid('resume')).isDisabled())) throw new Error('RESUME is enabled while nothing is held');

      const robotAxes = await page.locator('[data-testid^="dest-j"]').count();
      const target = [-120, 120, -150, 200, 0, 0, 0, 0].slice(0, robotAxes);
      await setDestination(page, 'joint', Object.fromEntries(target.map((v, i) => [`j${i + 1}`, v])));
      const startJ1 = await num(page, 'current-axis-1');
      await page.click(tid('go'));
      await page.waitForSelector(`${tid('state')}[data-state="MOVING"]`, { timeout: STEP_MS });
      // Hold once the arm is seen moving (axis 1 two degrees on its way), not after a guess.
      await page.waitForFunction(
        (start) => Math.abs(Number(document.querySelector('[data-testid="current-axis-1"]')?.textContent ?? NaN) - start) > 2,
        startJ1,
        { timeout: STEP_MS },
      );
      await page.click(tid('hold'));
      // HELD, or the controller's refusal of HOLD, whichever comes first.
      const held = await page.waitForFunction(
        () => {
          const state = document.querySelector('[data-testid="state"]')?.getAttribute('data-state');
          if (state === 'HELD') return 'HELD';
          const log = document.querySelector('[data-testid="command-log"]')?.textContent ?? '';
          const nak = /NAK HOLD: [^\n]*?(?=\d\d:\d\d:\d\d|$)/.exec(log);
          return nak ? nak[0] : false;
        },
        null,
        { timeout: STEP_MS },
      );
      const heldWhy = await held.jsonValue();
      if (heldWhy !== 'HELD') throw new Error(`HOLD was refused: ${heldWhy}`);
      await page.waitForSelector(`${tid('command-log')}:has-text("ACK HOLD")`, { timeout: STEP_MS });
      // The held motion keeps its request open: no INF/ABS for the MOVJ yet.
      if (count(await logText(), /INF MOVJ|ABS MOVJ/g) !== endsBefore) throw new Error('the held MOVJ already ended (INF/ABS)');
      const heldAt = await num(page, 'current-axis-1');
      if (Math.abs(heldAt - target[0]) < 1) throw new Error(`axis 1 is already at its target (${heldAt}) when held`);
      await page.waitForSelector(`${tid('resume')}:not([disabled])`, { timeout: STEP_MS });
      await shot(page, '#panel-control', 'held.png');

      await page.click(tid('resume'));
      await page.waitForSelector(`${tid('command-log')}:has-text("ACK RESUME")`, { timeout: STEP_MS });
      await page.waitForSelector(`${tid('state')}[data-state="MOVING"], ${tid('state')}[data-state="IDLE"]`, {
        timeout: STEP_MS,
      });
      // The same request ends with INF, at the same target.
      await page.waitForFunction(
        (n) => ((document.querySelector('[data-testid="command-log"]')?.textContent ?? '').match(/INF MOVJ|ABS MOVJ/g) ?? []).length > n,
        endsBefore,
        { timeout: STEP_MS },
      );
      const end = await logText();
      if (count(end, /ABS MOVJ/g) !== absBefore) throw new Error(`the resumed MOVJ was aborted: ${end.slice(-300)}`);
      await page.waitForSelector(`${tid('state')}[data-state="IDLE"]`, { timeout: STEP_MS });
      // The last datagrams may trail the state by a period or two: wait for every axis.
      const atTarget = (want) =>
        want.every(
          (t, i) => Math.abs(Number(document.querySelector(`[data-testid="current-axis-${i + 1}"]`)?.textContent ?? NaN) - t) <= 0.01,
        );
      try {
        await page.waitForFunction(atTarget, target, { timeout: STEP_MS });
      } catch {
        const at = [];
        for (let i = 0; i < robotAxes; i++) at.push(await num(page, `current-axis-${i + 1}`));
        throw new Error(`the axes ended at ${at.join(' ')}, not ${target.join(' ')}`);
      }
      if (!(await page.locator(tid('resume')).isDisabled())) throw new Error('RESUME stays enabled after the motion ended');
    });

    let stopState = '';
    await step('E-STOP during a long move', async () => {
      await page.click(tid('tab-simulator'));
      // The speed slider sends SPEED when released.
      await page.locator(tid('speed-slider')).evaluate((el) => {
        el.value = '20';
        el.dispatchEvent(new Event('input', { bubbles: true }));
        el.dispatchEvent(new Event('change', { bubbles: true }));
      });
      await page.waitForSelector(`${tid('current-speed')}:has-text("20 %")`, { timeout: STEP_MS });
      // A request typed in the command line.
      await page.fill(tid('raw-command'), 'WHERE');
      await page.press(tid('raw-command'), 'Enter');
      await page.waitForSelector(`${tid('command-log')}:has-text("ACK WHERE j=")`, { timeout: STEP_MS });
      const robotAxes = await page.locator('[data-testid^="dest-j"]').count();
      const far = [150, -120, 200, 250, 0, 0, 0, 0].slice(0, robotAxes);
      await setDestination(page, 'joint', Object.fromEntries(far.map((v, i) => [`j${i + 1}`, v])));
      await page.click(tid('go'));
      await page.waitForSelector(`${tid('state')}[data-state="MOVING"]`, { timeout: STEP_MS });
      await sleep(300);
      await page.click(tid('estop'));
      // The controller's fault state for an E-stop is ESTOP (RESET leaves it, as ERROR).
      await page.waitForSelector(`${tid('state')}[data-state="ESTOP"]`, { timeout: STEP_MS });
      stopState = (await page.locator(tid('state')).getAttribute('data-state')) ?? '';
      await page.waitForSelector(`${tid('header-error')}:has-text("201 emergency stop")`, { timeout: STEP_MS });
      await page.waitForFunction(
        () => /ABS MOVJ: 201/.test(document.querySelector('[data-testid="command-log"]')?.textContent ?? ''),
        null,
        { timeout: STEP_MS },
      );
      await sleep(300);
      await shot(page, null, 'full.png');
    });
    log(`     state after E-STOP: ${stopState}`);

    await step('RESET clears the E-stop', async () => {
      await page.click(tid('reset'));
      await page.waitForSelector(`${tid('state')}[data-state="IDLE"]`, { timeout: STEP_MS });
    });

    await step('Save trace: TRACE SAVE names a .wrctrace file, and the viewer opens it', async () => {
      await page.fill(tid('trace-name'), 'e2e_session');
      await page.click(tid('trace-save'));
      await page.waitForSelector(`${tid('trace-saved')}[data-state="saved"], ${tid('trace-saved')}[data-state="refused"]`, {
        timeout: STEP_MS,
      });
      const saved = page.locator(tid('trace-saved'));
      const text = (await saved.textContent()) ?? '';
      if ((await saved.getAttribute('data-state')) !== 'saved') throw new Error(`TRACE SAVE failed: ${text}`);
      const file = (await saved.getAttribute('data-file')) ?? '';
      if (!file.startsWith('/') || !file.endsWith('e2e_session.wrctrace')) {
        throw new Error(`the saved file is ${JSON.stringify(file)}, not an absolute path ending in e2e_session.wrctrace`);
      }
      await page.waitForSelector(`${tid('command-log')}:has-text("file=${file}")`, { timeout: STEP_MS });
      await shot(page, '.trace-card', 'trace-saved.png');

      // The controller's own file, read by the GUI's reader.
      await page.click(tid('tab-simulator'));
      await page.setInputFiles(tid('trace-open'), file);
      await page.waitForSelector(`${tid('trace-bar')}[data-open="1"], ${tid('trace-error')}:not(:empty)`, { timeout: STEP_MS });
      const error = (await page.locator(tid('trace-error')).textContent()) ?? '';
      if (error) throw new Error(`the viewer refuses the controller's trace: ${error}`);
      const info = (await page.locator(tid('trace-file')).textContent()) ?? '';
      if (!/TRACE SAVE/.test(info) || /; 0 samples/.test(info)) throw new Error(`the trace says ${JSON.stringify(info)}`);
      // Its last sample: after RESET, standing.
      const max = Number(await page.locator(tid('trace-scrubber')).getAttribute('max'));
      await scrubTo(page, max);
      await page.waitForSelector(`${tid('trace-state')}[data-state="IDLE"]`, { timeout: STEP_MS });
      await shot(page, '#panel-simulator', 'trace-saved-viewer.png');
      await page.click(tid('trace-close'));
    });

    if (pageErrors.length > 0) throw new Error(`errors in the page:\n  ${pageErrors.join('\n  ')}`);
  } catch (e) {
    // What the operator would have seen: the command log and the error text.
    try {
      const logText = page ? await page.locator(tid('command-log')).innerText({ timeout: 2000 }) : '';
      pageLog = logText.split('\n').slice(-40).join('\n');
    } catch {
      /* the page is gone */
    }
    throw e;
  } finally {
    await browser.close().catch(() => undefined);
  }
}

let failed = null;
try {
  await withTimeout(run(), TOTAL_MS, 'the whole e2e test');
} catch (e) {
  failed = e;
} finally {
  await stopWrc();
  if (stateDir) rmSync(stateDir, { recursive: true, force: true });
}

const summary = results.map((r) => `${r.ok ? 'ok  ' : 'FAIL'} ${r.label} (${(r.ms / 1000).toFixed(1)} s)`).join('\n');
try {
  mkdirSync(outDir, { recursive: true });
  writeFileSync(join(outDir, 'e2e-summary.txt'), `${summary}\n${failed ? `\nFAILED: ${failed.message}\n` : ''}`);
} catch {
  /* best effort */
}
if (failed) {
  const why = `gui e2e FAILED after ${secs().trim()} s: ${failed.message}`;
  console.error(`\n${why}`);
  if (wrcOut.trim()) console.error(`--- wrc up output (last 4000 chars) ---\n${wrcOut.slice(-4000)}`);
  if (events.trim()) console.error(`--- controller events (last 40) ---\n${events.trim().split('\n').slice(-40).join('\n')}`);
  if (pageLog.trim()) console.error(`--- the page's command log (last 40 lines) ---\n${pageLog}`);
  // Again at the end, where a CI log's tail shows it.
  console.error(`\n${summary}\n${why}`);
  process.exit(1);
}
const passed = results.filter((r) => r.ok).length;
console.log(`\ngui e2e: ${passed} passed, 0 failed in ${secs().trim()} s; screenshots in ${outDir}`);
process.exit(0);
