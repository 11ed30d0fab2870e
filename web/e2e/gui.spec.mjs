// End-to-end test of the web GUI in real headless Chromium against a real `wrc up` (fixtures.mjs):
// one operator's session, step by step, each step on the state the last one left. Screenshots
// go to WRC_TEST_OUTPUT (playwright.config.mjs says how to run it).

import { mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { encodeTrace } from './trace-fixture.mjs';
import { expect, newProgram, test } from './fixtures.mjs';
import { OUT_DIR, REPO, STEP_MS } from './settings.mjs';

// ---------------------------------------------------------------------------------------------
// page helpers

function angleDiff(a, b) {
  let d = (((a - b) % 360) + 540) % 360 - 180;
  if (d === -180) d = 180;
  return Math.abs(d);
}

async function num(page, id) {
  const t = (await page.getByTestId(id).textContent()) ?? '';
  return Number(t.trim());
}

/** Wait until Current shows the pose (within 0.01) and the robot stands (IDLE). */
async function expectPose(page, x, y, z, yaw) {
  await expect
    .poll(
      async () => {
        const nak = page.getByTestId('last-nak');
        if (await nak.isVisible()) return `refused: ${await nak.textContent()}`;
        const cur = {
          x: await num(page, 'current-x'),
          y: await num(page, 'current-y'),
          z: await num(page, 'current-z'),
          yaw: await num(page, 'current-yaw'),
        };
        const state = await page.getByTestId('state').getAttribute('data-state');
        const there =
          Math.abs(cur.x - x) <= 0.01 &&
          Math.abs(cur.y - y) <= 0.01 &&
          Math.abs(cur.z - z) <= 0.01 &&
          angleDiff(cur.yaw, yaw) <= 0.01 &&
          state === 'IDLE';
        return there ? 'there' : `x=${cur.x} y=${cur.y} z=${cur.z} yaw=${cur.yaw} state=${state}`;
      },
      { message: `the robot stands at x=${x} y=${y} z=${z} yaw=${yaw}`, intervals: [100] },
    )
    .toBe('there');
}

async function setDestination(page, mode, values) {
  await page.getByTestId(`mode-${mode}`).click();
  for (const [k, v] of Object.entries(values)) await page.getByTestId(`dest-${k}`).fill(String(v));
}

async function setEditorText(page, text) {
  await page.locator('#panel-editor .cm-content').click();
  await page.keyboard.press('Control+A');
  await page.keyboard.press('Delete');
  await page.keyboard.insertText(text);
  const lines = page.locator('#panel-editor .cm-line');
  const got = (await lines.allTextContents()).join('\n');
  expect(got.trim(), 'the editor holds the program').toBe(text.trim());
}

/** The joint values the 3D view draws now (the simulator's read-back of its scene), or null. */
function drawnPose(page) {
  return page.evaluate(() => window.wrc?.sim?.drawnPose() ?? null);
}

/** Wait until the 3D view draws the joint values `want` (within 0.01). */
async function expectDrawn(page, want, what) {
  await expect
    .poll(
      async () => {
        const p = await drawnPose(page);
        if (!p) return 'no robot drawn (no WebGL, or ROBOT not answered)';
        return Object.entries(want).every(([k, v]) => Math.abs(p[k] - v) <= 0.01) ? 'drawn' : JSON.stringify(p);
      },
      { message: `the 3D view draws ${what} (${JSON.stringify(want)})` },
    )
    .toBe('drawn');
}

/** Move the trace scrubber to sample `i` as a drag would (an input event). */
async function scrubTo(page, i) {
  await page.getByTestId('trace-scrubber').evaluate((el, v) => {
    el.value = String(v);
    el.dispatchEvent(new Event('input', { bubbles: true }));
  }, i);
}

/** Set the speed slider as a drag that ends there would: SPEED is sent when it is released. */
async function setSpeed(page, percent) {
  await page.getByTestId('speed-slider').evaluate((el, v) => {
    el.value = String(v);
    el.dispatchEvent(new Event('input', { bubbles: true }));
    el.dispatchEvent(new Event('change', { bubbles: true }));
  }, percent);
  await expect(page.getByTestId('current-speed')).toContainText(`${percent} %`);
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
      configToml: readFileSync(join(REPO, 'config', 'default.toml'), 'utf8'),
      savedAtNs: t0 + 3_000_000_000,
    },
    samples,
    messages,
  });
}

/** Screenshot `selector` (the whole page when null) into WRC_TEST_OUTPUT, and attach it. */
async function shot(page, selector, file) {
  const path = join(OUT_DIR, file);
  if (selector) await page.locator(selector).screenshot({ path });
  else await page.screenshot({ path, fullPage: true });
  await test.info().attach(file, { path, contentType: 'image/png' });
}

/** The number of matches of `re` in the command log. */
async function logCount(page, re) {
  const text = (await page.getByTestId('command-log').textContent()) ?? '';
  return (text.match(re) ?? []).length;
}

// A step makes several waits of up to STEP_MS each; on a loaded 2-core machine the browser
// alone can take seconds per click, so a step as a whole gets twice that.
const step = (title, body) => test.step(title, body, { timeout: 2 * STEP_MS });

// Two animation frames: whatever changed has been drawn (for the screenshots).
const framesDrawn = (page) =>
  page.evaluate(() => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done))));

// ---------------------------------------------------------------------------------------------
// the test

const BAD_PROGRAM = `' e2e test program: TOTAL is never assigned
SPEED 100
MOVEP POSE(260, 40, 5, 0)
PRINT "e2e total", TOTAL
`;
const GOOD_PROGRAM = `' e2e test program
SPEED 100
TOTAL = 1 + 2
MOVEP POSE(260, 40, 5, 0)
PRINT "e2e total", TOTAL
`;

const FAULT_PROGRAM = `' e2e test program: division by zero at run time
X = 1
X = X - 1
PRINT 1 / X
`;

test('an operator session: control, motions, trace viewer, editor, plots, wafers, hold, E-stop, trace save', async ({
  page,
  wrc,
  pageErrors,
}) => {
  mkdirSync(OUT_DIR, { recursive: true });
  const id = (testId) => page.getByTestId(testId);

  await step('open the page and connect', async () => {
    await page.goto(wrc.url);
    await expect(id('connection')).toHaveAttribute('data-connected', '1');
    await expect(id('current-axis-1')).toBeVisible(); // ROBOT answered
    await expect(page.locator('#panel-control')).toBeVisible();
    for (const panel of ['panel-simulator', 'panel-wafers', 'panel-editor', 'panel-plots']) {
      await expect(page.locator(`#${panel}`)).toHaveCount(1);
    }
    await expect(page.locator('#panel-simulator'), 'the Simulator tab is shown first').toBeVisible();
  });

  await step('take control', async () => {
    await id('take-control').click();
    await expect(id('lock-owner')).toHaveAttribute('data-mine', '1');
  });

  await step('HOME: state IDLE and homed', async () => {
    await id('home').click();
    await expect(id('command-log')).toContainText('INF HOME');
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    await expect(id('homed')).toHaveAttribute('data-homed', '1');
  });

  // At the bottom of the Z axis the arm passes under every station of the demo cell (at
  // 20 mm this PTP would end in LP2's front: NAK 117).
  await step('PTP from the Destination panel: MOVP 250 100 0 30', async () => {
    await setDestination(page, 'ptp', { x: 250, y: 100, z: 0, yaw: 30 });
    await id('go').click();
    await expectPose(page, 250, 100, 0, 30);
  });

  await step('Straight move: MOVL 300 -50 0 0', async () => {
    await setDestination(page, 'line', { x: 300, y: -50, z: 0, yaw: 0 });
    await id('go').click();
    await expectPose(page, 300, -50, 0, 0);
  });

  await step('a NAK is shown: MOVP out of reach', async () => {
    await setDestination(page, 'ptp', { x: 1000, y: 0, z: 0, yaw: 0 });
    await id('go').click();
    await expect(id('last-nak')).toBeVisible();
    await expect(id('last-nak')).toContainText('111');
  });

  await step('toggle output 3 on', async () => {
    await id('output-3').click();
    await expect(id('output-3')).toHaveAttribute('data-on', '1');
  });

  await step('screenshots: control and simulator', async () => {
    await framesDrawn(page); // the 3D view has drawn the last pose
    await shot(page, '#panel-control', 'control.png');
    await shot(page, '#panel-simulator', 'simulator.png');
  });

  await step('Trace viewer: a corrupt file is refused with a sentence', async () => {
    const bad = fixtureTrace();
    bad[40] ^= 0x10; // inside the meta section
    const path = join(wrc.stateDir, 'corrupt.wrctrace');
    writeFileSync(path, bad);
    await id('tab-simulator').click();
    await id('trace-open').setInputFiles(path);
    await expect(id('trace-error')).toBeVisible();
    await expect(id('trace-error')).toContainText('corrupt.wrctrace is corrupt: its meta section fails its CRC-32 check');
    await expect(id('trace-bar'), 'a corrupt trace is not opened').toHaveAttribute('data-open', '0');
  });

  await step('Trace viewer: scrub a trace, the 3D view follows it; Close returns to live', async () => {
    const path = join(wrc.stateDir, 'fixture.wrctrace');
    writeFileSync(path, fixtureTrace());
    await id('trace-open').setInputFiles(path);
    await expect(id('trace-bar')).toHaveAttribute('data-open', '1');
    await expect(id('trace-error'), 'the trace is not refused').toBeEmpty();
    await expect(id('trace-note'), 'the trace is drawn with its own robot').toBeEmpty();
    await expect(id('trace-state')).toHaveAttribute('data-state', 'IDLE');
    await expectDrawn(page, { j1: -75, z: 0 }, 'sample 0');

    await scrubTo(page, 150);
    await expect(id('trace-state')).toHaveAttribute('data-state', 'MOVING');
    await expect(id('trace-time')).toHaveText(/^1\.500 s \/ 2\.990 s/);
    await expect(id('trace-inputs')).toHaveText('0x00004004');
    const current = page.locator('[data-testid="trace-message"][data-current="1"]');
    await expect(current, 'one message is highlighted at 1.5 s').toHaveCount(1);
    await expect(current).toContainText('ACK 5');
    await expect(id('trace-message'), 'the messages within ±1 s of 1.5 s').toHaveCount(3);
    // Half-way: J1 at -15°, Z at 25 mm.
    await expectDrawn(page, { j1: -15, z: 25 }, 'the trace at 1.5 s');
    // The pose is in the scene; two animation frames later it is on the canvas.
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    await shot(page, '#panel-simulator', 'trace-viewer.png');

    // Play runs on from the scrubber in the trace's time and stops at its end (1.5 s later;
    // a click can take longer than that on a loaded machine, so the end is not raced).
    await id('trace-play').click();
    await expect(id('trace-play')).toHaveAttribute('data-playing', '0');
    await expect(id('trace-scrubber'), 'playing stops at the last sample').toHaveValue('299');
    await expectDrawn(page, { j1: 45, z: 50 }, 'the end of the trace');
    await expect(id('trace-state')).toHaveAttribute('data-state', 'IDLE');

    await id('trace-close').click();
    await expect(id('trace-bar')).toHaveAttribute('data-open', '0');
    // Live again: the drawn J1 is the controller's (the Control panel's current position).
    await expect
      .poll(
        () =>
          page.evaluate(() => {
            const live = Number(document.querySelector('[data-testid="current-axis-1"]')?.textContent ?? NaN);
            const drawn = window.wrc?.sim?.drawnPose();
            return drawn ? Math.abs(drawn.j1 - live) < 0.01 : false;
          }),
        { message: 'the 3D view draws the live J1 again' },
      )
      .toBe(true);
  });

  await step('Editor: compile a program with an error, see it inline and in the problems', async () => {
    await id('tab-editor').click();
    await expect(page.locator('#panel-editor .cm-content')).toBeVisible();
    await newProgram(page, 'e2e_demo');
    await setEditorText(page, BAD_PROGRAM);
    await id('editor-compile').click();
    await expect(id('problem').filter({ hasText: 'TOTAL' }).first()).toBeVisible();
    await expect(id('problem').first(), 'the problem is at 4:20').toContainText('4:20');
    // The inline mark is on line 4, under TOTAL.
    const mark = page.locator('#panel-editor .cm-line').nth(3).locator('.cm-lintRange-error').first();
    await expect(mark).toContainText('TOTAL');
    await expect(id('editor-status')).toContainText('1 error');
    await shot(page, '#panel-editor', 'editor-error.png');
  });

  await step('Editor: fix it, compile, run to INF and see PRINT in the console', async () => {
    await setEditorText(page, GOOD_PROGRAM);
    await id('editor-compile').click();
    await expect(id('editor-status')).toContainText('compiled');
    await expect(page.locator('#panel-editor .cm-lintRange-error'), 'the error mark goes').toHaveCount(0);
    await id('editor-run').click();
    await expect(id('console')).toContainText('e2e total 3');
    await expect(id('console')).toContainText('INF program e2e_demo ended');
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    await shot(page, '#panel-editor', 'editor.png');
  });

  await step('Editor: a run-time error ends with ABS and marks its line', async () => {
    await newProgram(page, 'e2e_fault');
    await setEditorText(page, FAULT_PROGRAM);
    await id('editor-run').click(); // uploads first: the text is new
    await expect(id('console')).toContainText('ABS 210');
    await expect(id('console'), 'the ABS names line 4').toContainText(/e2e_fault line 4/);
    await expect(page.locator('#panel-editor .cm-line.cm-abs-line').first()).toContainText('1 / X');
  });

  await step('Plots tab', async () => {
    await id('tab-plots').click();
    await expect(page.locator('#panel-plots')).toBeVisible();
    // The pulse chart has samples and the task table its rows.
    await expect(page.locator('#panel-plots .plot-empty')).toBeHidden();
    await expect(page.locator('#panel-plots .plot-table tbody tr').first()).toBeVisible();
    await framesDrawn(page);
    await shot(page, '#panel-plots', 'plots.png');
  });

  await step('Wafers tab: a column per station, a fresh map is all unmapped', async () => {
    await id('tab-wafers').click();
    await expect(page.locator('#panel-wafers')).toBeVisible();
    await expect(id('wafer-station-LP1')).toBeVisible(); // WAFERS answered
    const slots = id('wafer-station-LP1').locator('[data-testid^="wafer-slot-LP1-"]');
    await expect(slots, 'LP1 shows 25 slots').toHaveCount(25);
    const states = await slots.evaluateAll((els) => els.map((e) => e.getAttribute('data-state')));
    expect(states.filter((s) => s !== 'unknown'), 'a fresh map shows only "unknown" slots').toEqual([]);
    // Slot 25 on top, like a cassette.
    await expect(slots.first(), 'the top slot').toHaveAttribute('data-testid', 'wafer-slot-LP1-25');
    await expect(id('wafer-hand'), 'the hand on a fresh map').toHaveAttribute('data-wafer', '');
    // Selecting an unmapped slot: GET stays disabled (nothing is sent), MAP is offered.
    await id('wafer-slot-LP1-3').click();
    await expect(id('wafer-slot-LP1-3')).toHaveAttribute('data-selected', '1');
    await expect(id('wafer-get'), 'GET for an unmapped slot').toBeDisabled();
    await expect(id('wafer-map'), 'MAP while this page holds control').toBeEnabled();
    await shot(page, '#panel-wafers', 'wafers.png');
  });

  await step('HOLD during a long move, RESUME to its target', async () => {
    await id('tab-simulator').click();
    await setSpeed(page, 20);
    const endsBefore = await logCount(page, /INF MOVJ|ABS MOVJ/g);
    const absBefore = await logCount(page, /ABS MOVJ/g);
    await expect(id('resume'), 'RESUME while nothing is held').toBeDisabled();

    const robotAxes = await page.locator('[data-testid^="dest-j"]').count();
    const target = [-120, 120, -150, 200, 0, 0, 0, 0].slice(0, robotAxes);
    await setDestination(page, 'joint', Object.fromEntries(target.map((v, i) => [`j${i + 1}`, v])));
    const startJ1 = await num(page, 'current-axis-1');
    await id('go').click();
    await expect(id('state')).toHaveAttribute('data-state', 'MOVING');
    // Hold once the arm is seen moving (axis 1 two degrees on its way), not after a guess.
    await expect
      .poll(async () => Math.abs((await num(page, 'current-axis-1')) - startJ1), { message: 'axis 1 moves', intervals: [50] })
      .toBeGreaterThan(2);
    await id('hold').click();
    // HELD, or the controller's refusal of HOLD, whichever comes first.
    await expect
      .poll(
        () =>
          page.evaluate(() => {
            const state = document.querySelector('[data-testid="state"]')?.getAttribute('data-state');
            if (state === 'HELD') return 'HELD';
            const log = document.querySelector('[data-testid="command-log"]')?.textContent ?? '';
            const nak = /NAK HOLD: [^\n]*?(?=\d\d:\d\d:\d\d|$)/.exec(log);
            return nak ? nak[0] : `state ${state}`;
          }),
        { message: 'HOLD holds the motion' },
      )
      .toBe('HELD');
    await expect(id('command-log')).toContainText('ACK HOLD');
    // The held motion keeps its request open: no INF/ABS for the MOVJ yet.
    expect(await logCount(page, /INF MOVJ|ABS MOVJ/g), 'INF/ABS of the held MOVJ').toBe(endsBefore);
    const heldAt = await num(page, 'current-axis-1');
    expect(Math.abs(heldAt - target[0]), `axis 1 when held (${heldAt}) is short of its target`).toBeGreaterThanOrEqual(1);
    await expect(id('resume')).toBeEnabled();
    await shot(page, '#panel-control', 'held.png');

    await id('resume').click();
    await expect(id('command-log')).toContainText('ACK RESUME');
    await expect(id('state')).toHaveAttribute('data-state', /^(MOVING|IDLE)$/);
    // The same request ends with INF, at the same target.
    await expect.poll(() => logCount(page, /INF MOVJ|ABS MOVJ/g), { message: 'the MOVJ ends' }).toBeGreaterThan(endsBefore);
    expect(await logCount(page, /ABS MOVJ/g), 'the resumed MOVJ is not aborted').toBe(absBefore);
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    // The last datagrams may trail the state by a period or two: wait for every axis.
    await expect
      .poll(
        async () => {
          const at = [];
          for (let i = 0; i < robotAxes; i++) at.push(await num(page, `current-axis-${i + 1}`));
          return at.every((p, i) => Math.abs(p - target[i]) <= 0.01) ? 'at target' : `at ${at.join(' ')}`;
        },
        { message: `the axes end at ${target.join(' ')}` },
      )
      .toBe('at target');
    await expect(id('resume'), 'RESUME after the motion ended').toBeDisabled();
  });

  await step('E-STOP during a long move', async () => {
    await id('tab-simulator').click();
    // Slow, as for HOLD: the E-stop must land while the arm moves.
    await setSpeed(page, 10);
    // A request typed in the command line.
    await id('raw-command').fill('WHERE');
    await id('raw-command').press('Enter');
    await expect(id('command-log')).toContainText('ACK WHERE j=');
    const robotAxes = await page.locator('[data-testid^="dest-j"]').count();
    const far = [150, -120, 200, 250, 0, 0, 0, 0].slice(0, robotAxes);
    await setDestination(page, 'joint', Object.fromEntries(far.map((v, i) => [`j${i + 1}`, v])));
    const before = await id('current-axis-1').textContent();
    await id('go').click();
    await expect(id('state')).toHaveAttribute('data-state', 'MOVING');
    // E-stop while the arm is really under way: once its position has changed.
    await expect(id('current-axis-1')).not.toHaveText(before ?? '');
    await id('estop').click();
    // The controller's fault state for an E-stop is ESTOP (RESET leaves it, as ERROR).
    await expect(id('state')).toHaveAttribute('data-state', 'ESTOP');
    await expect(id('header-error')).toContainText('201 emergency stop');
    await expect(id('command-log')).toContainText(/ABS MOVJ: 201/);
    await framesDrawn(page);
    await shot(page, null, 'full.png');
  });

  await step('RESET clears the E-stop', async () => {
    await id('reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
  });

  await step('Save trace: TRACE SAVE names a .wrctrace file, and the viewer opens it', async () => {
    await id('trace-name').fill('e2e_session');
    await id('trace-save').click();
    const saved = id('trace-saved');
    await expect(saved).toHaveAttribute('data-state', /^(saved|refused)$/);
    await expect(saved, 'TRACE SAVE saves').toHaveAttribute('data-state', 'saved');
    const file = (await saved.getAttribute('data-file')) ?? '';
    expect(file, 'the saved file is an absolute path').toMatch(/^\/.*e2e_session\.wrctrace$/);
    await expect(id('command-log')).toContainText(`file=${file}`);
    await shot(page, '.trace-card', 'trace-saved.png');

    // The controller's own file, read by the GUI's reader.
    await id('tab-simulator').click();
    await id('trace-open').setInputFiles(file);
    await expect(page.locator('[data-testid="trace-bar"][data-open="1"], [data-testid="trace-error"]:not(:empty)')).toBeVisible();
    await expect(id('trace-error'), "the viewer reads the controller's trace").toBeEmpty();
    await expect(id('trace-file')).toContainText('TRACE SAVE');
    await expect(id('trace-file'), 'the trace holds samples').not.toContainText('; 0 samples');
    // Its last sample: after RESET, standing.
    const max = Number(await id('trace-scrubber').getAttribute('max'));
    await scrubTo(page, max);
    await expect(id('trace-state')).toHaveAttribute('data-state', 'IDLE');
    await shot(page, '#panel-simulator', 'trace-saved-viewer.png');
    await id('trace-close').click();
  });

  expect(pageErrors, 'errors in the page').toEqual([]);
});
