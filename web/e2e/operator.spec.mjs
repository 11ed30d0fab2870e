// End-to-end tests of what an operator on a night shift needs to see and reach (issue 39), in
// real headless Chromium against a real `wrc up` (fixtures.mjs): the E-STOP never behind a
// dialog and honest while offline, refusals and stops in the status line, controls disabled
// with their reason, the running program in the header, the destination read from the robot
// after a reconnection, the other tab named as such, the editor opening stored programs and
// libraries and showing a library's source while stepping in it, the 3D view idle at rest
// with LP1's wafers instanced and its stations named, and the layout at 1280 × 800. Every wait
// waits for a condition the page shows.

import { join } from 'node:path';
import { expect, newProgram, test } from './fixtures.mjs';
import { connectHost } from './host-client.mjs';
import { OUT_DIR, STEP_MS } from './settings.mjs';

const step = (title, body) => test.step(title, body, { timeout: 2 * STEP_MS });

async function shot(page, selector, file) {
  const path = join(OUT_DIR, file);
  if (selector) await page.locator(selector).screenshot({ path });
  else await page.screenshot({ path });
  await test.info().attach(file, { path, contentType: 'image/png' });
}

/** Open the page and wait until it is connected and knows the robot. */
async function open(page, url) {
  await page.goto(url);
  await expect(page.getByTestId('connection')).toHaveAttribute('data-connected', '1');
  await expect(page.getByTestId('current-axis-1')).toBeVisible();
}

/** Replace the editor's text, as typed. */
async function setEditorText(page, text) {
  await page.locator('#panel-editor .cm-content').click();
  await page.keyboard.press('Control+A');
  await page.keyboard.press('Delete');
  await page.keyboard.insertText(text);
  await page.keyboard.press('Escape');
}

/** Upload `text` as program `name` from a host client (as `wrc run` stores a library). */
async function upload(host, name, text) {
  const lines = text.replace(/\n$/, '').split('\n');
  // The host client sends one request line; an UPLOAD's text follows it on the socket.
  const reply = host.send(`UPLOAD ${name}\n${lines.join('\n')}\n.`);
  expect(await reply).toMatch(/^ACK \d+ name=/);
}

test('E-STOP offline: it looks offline, says to use the physical E-stop, and says so when pressed', async ({ page, lonelyUi }) => {
  const id = (t) => page.getByTestId(t);
  await page.goto(lonelyUi.url);
  await expect(id('connection')).toHaveAttribute('data-connected', '0');
  await expect(id('estop')).toHaveAttribute('data-offline', '1');
  await expect(id('estop-sub')).toHaveText('offline: use the physical E-stop');
  await expect(id('estop')).toBeEnabled();
  await id('estop').click();
  await expect(id('status-line')).toHaveAttribute('data-level', 'alarm');
  await expect(id('status-tag')).toHaveText('E-STOP NOT SENT');
  await expect(id('status-text')).toContainText('use the physical E-stop');
});

test('an operator session: status line, disabled controls, program in the header, E-STOP over every dialog, reconnection', async ({
  page,
  wrc,
  pageErrors,
}) => {
  const id = (t) => page.getByTestId(t);
  await open(page, wrc.url);

  await step('before HOME: Go and jog are disabled and say why; Home is not', async () => {
    await id('take-control').click();
    await expect(id('lock-owner')).toHaveAttribute('data-mine', '1');
    await expect(id('go')).toBeDisabled();
    await expect(id('go')).toHaveAttribute('title', /the robot is not homed: HOME first/);
    await expect(id('jog-plus-1')).toBeDisabled();
    await expect(id('motion-why')).toHaveText('Go: the robot is not homed: HOME first');
    await expect(id('home')).toBeEnabled();
    await expect(id('status-line')).toHaveAttribute('data-level', 'none');
  });

  await step('HOME; a refusal stays in the status line until dismissed', async () => {
    await id('home').click();
    await expect(id('command-log')).toContainText('INF HOME');
    await expect(id('go')).toBeEnabled();
    await id('mode-ptp').click();
    for (const [k, v] of Object.entries({ x: 1000, y: 0, z: 0, yaw: 0 })) await id(`dest-${k}`).fill(String(v));
    await id('go').click();
    await expect(id('status-line')).toHaveAttribute('data-level', 'refusal');
    await expect(id('status-tag')).toHaveText('NAK 111');
    await expect(id('status-text')).toContainText('MOVP 1000 0 0 0 refused');
    // Still there on another tab.
    await id('tab-plots').click();
    await expect(id('status-tag')).toHaveText('NAK 111');
    await id('status-dismiss').click();
    await expect(id('status-line')).toHaveAttribute('data-level', 'none');
  });

  await step('the buttons stay where they are when the Posture row goes (PTP, Straight, Joint)', async () => {
    const goY = async () => (await id('go').boundingBox()).y;
    await id('mode-ptp').click();
    const ptp = await goY();
    await id('mode-line').click();
    expect(await goY(), 'Go with Straight').toBe(ptp);
    await id('mode-joint').click();
    expect(await goY(), 'Go with Joint').toBe(ptp);
  });

  await step('the joint fields are read from the robot after a reconnection, never 0 0 0 0', async () => {
    await id('mode-joint').click();
    const before = await id('current-axis-1').textContent();
    expect(Number(before), 'at home J1 is not 0').not.toBe(0);
    // The page's own WebSocket drops; it reconnects within a second.
    await page.evaluate(() => window.wrc.bus.ws.close());
    await expect(id('connection')).toHaveAttribute('data-connected', '0');
    await expect(id('connection')).toHaveAttribute('data-connected', '1');
    await expect.poll(async () => Number(await id('dest-j1').inputValue()), { message: 'dest-j1 read from WHERE' }).toBe(Number(before));
    await expect(id('go')).toBeEnabled();
  });

  await step('a program paused at a breakpoint shows in the header; motions are refused meanwhile', async () => {
    await id('tab-editor').click();
    await newProgram(page, 'e2e_header');
    await setEditorText(page, "' header test\nX = 1\nX = 2\nPRINT X\n");
    await page.locator('#panel-editor .cm-lineNumbers .cm-gutterElement').filter({ hasText: /^3$/ }).click();
    await id('editor-run').click();
    await expect(id('header-program')).toHaveText('e2e_header paused at e2e_header:3');
    await expect(id('header-program')).toHaveAttribute('data-state', 'paused');
    await expect(id('home')).toBeDisabled();
    await expect(id('home')).toHaveAttribute('title', /e2e_header is paused: CONTINUE or ABORT it/);
    await expect(id('state'), 'the state badge is the robot’s, not the program’s').toHaveAttribute('data-state', 'IDLE');
    await id('editor-continue').click();
    await expect(id('header-program')).toBeHidden();
    await expect(id('home')).toBeEnabled();
  });

  await step('a stale red status clears once the text is fixed', async () => {
    await setEditorText(page, "PRINT TOTAL\n");
    await id('editor-compile').click();
    await expect(id('editor-status')).toHaveAttribute('data-kind', 'err');
    await setEditorText(page, "TOTAL = 3\nPRINT TOTAL\n");
    await expect(id('editor-status')).not.toHaveAttribute('data-kind', 'err');
  });

  await step('E-STOP while the editor asks to discard edits: ESTOP goes out, a stop not an error', async () => {
    await setEditorText(page, "PRINT 1\n' edited, not stored\n");
    await id('editor-open').selectOption('example:fig7_ptp');
    await expect(id('confirm-dialog')).toBeVisible();
    await expect(id('confirm-title')).toHaveText('Discard the edits of e2e_header?');
    await id('estop').click(); // Playwright checks the E-STOP itself receives the click
    await expect(id('state')).toHaveAttribute('data-state', 'ESTOP');
    await expect(id('command-log')).toContainText('ACK ESTOP');
    await expect(id('status-line')).toHaveAttribute('data-level', 'stop');
    await expect(id('status-tag')).toHaveText('E-STOP');
    await expect(id('header-error')).toHaveAttribute('data-kind', 'stop');
    await expect(id('confirm-dialog'), 'the dialog is still there to answer').toBeVisible();
    await id('confirm-cancel').click();
    await expect(id('go')).toBeDisabled();
    await expect(id('motion-why')).toContainText('the robot is in ESTOP: release the E-stop and RESET first');
    await id('reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
  });

  await step('E-STOP while a name is asked (Save as…)', async () => {
    await id('editor-save-as').click();
    await expect(id('name-dialog')).toBeVisible();
    await id('estop').click();
    await expect(id('state')).toHaveAttribute('data-state', 'ESTOP');
    await id('name-dialog-cancel').click();
    await id('reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    await shot(page, null, 'operator.png');
  });

  expect(pageErrors).toEqual([]);
});

test('another tab of this browser holds control: named as such, and its breakpoints do not fail with NAK 120', async ({
  page,
  context,
  wrc,
  pageErrors,
}) => {
  await open(page, wrc.url);
  await page.getByTestId('tab-editor').click();
  await newProgram(page, 'e2e_tabs');
  await setEditorText(page, "X = 1\nX = 2\n");
  await page.locator('#panel-editor .cm-lineNumbers .cm-gutterElement').filter({ hasText: /^2$/ }).click();
  await page.getByTestId('take-control').click();
  await expect(page.getByTestId('lock-owner')).toHaveAttribute('data-mine', '1');

  const other = await context.newPage();
  await open(other, wrc.url);
  const owner = other.getByTestId('lock-owner');
  await expect(owner).toHaveText(/^another tab of this browser \(gui\d+\)$/);
  await expect(owner).toHaveAttribute('data-peer', '1');
  await expect(other.getByTestId('go')).toHaveAttribute('title', /control is held by another tab of this browser/);
  // The editor (and its breakpoint) is restored in this tab too: it is kept, not refused.
  await other.getByTestId('tab-editor').click();
  await expect(other.getByTestId('editor-name')).toHaveText('e2e_tabs');
  await expect(other.getByTestId('console')).not.toContainText('NAK 120');
  await expect(other.getByTestId('status-line')).toHaveAttribute('data-level', 'none');
  // Released: it is nobody's, and the other tab's breakpoint goes to the controller quietly.
  await page.getByTestId('take-control').click();
  await expect(owner).toHaveText('nobody');
  await expect(other.getByTestId('console')).not.toContainText('NAK');
  await other.close();
  expect(pageErrors).toEqual([]);
});

test('the editor opens stored programs and libraries, and shows the library while stepping in it', async ({ page, wrc, pageErrors }) => {
  const id = (t) => page.getByTestId(t);
  const host = await connectHost(wrc.hostPort);
  const lib = "' e2e_lib: a library\nSUB greet(n)\n  PRINT \"hello\", n\nENDSUB\n";
  const main = "INCLUDE \"e2e_lib\"\nCALL greet(2)\nPRINT \"done\"\n";
  try {
    await upload(host, 'e2e_lib', lib);
    await upload(host, 'e2e_main', main);
  } finally {
    host.close();
  }
  await open(page, wrc.url);
  await id('tab-editor').click();
  await id('editor-refresh').click();
  await expect(id('editor-open').locator('option[value="stored:e2e_lib"]')).toHaveCount(1);
  await id('editor-open').selectOption('stored:e2e_lib');
  await expect(id('editor-name')).toHaveText('e2e_lib');
  await expect(page.locator('#panel-editor .cm-line').nth(1)).toHaveText('SUB greet(n)');
  await id('editor-open').selectOption('stored:e2e_main');
  await expect(id('editor-name')).toHaveText('e2e_main');
  await expect(page.locator('#panel-editor .cm-line').first()).toHaveText('INCLUDE "e2e_lib"');
  await expect(page.locator('#panel-editor')).toHaveAttribute('data-edited', '0');

  await id('editor-run-paused').click();
  await expect(id('header-program')).toHaveAttribute('data-state', 'paused');
  await id('editor-step').click(); // into greet
  await expect(id('library-peek')).toBeVisible();
  await expect(id('library-title')).toContainText('e2e_lib — library, read-only');
  await expect(page.locator('[data-testid="library-source"] .lib-line.current')).toContainText('PRINT "hello", n');
  await shot(page, '#panel-editor', 'editor-library.png');
  await id('editor-step-out').click();
  await expect(id('library-peek')).toBeHidden();
  await id('editor-continue').click();
  await expect(id('console')).toContainText('done');
  expect(pageErrors).toEqual([]);
});

test('at 1280 × 800: the header, the Wafers columns and the 3D view beside them fit; at rest the 3D view draws nothing', async ({
  page,
  wrc,
  pageErrors,
}) => {
  const id = (t) => page.getByTestId(t);
  // The cell first (LP1 mapped full), then the page: on a 2-core machine the page's start
  // (its scripts, the worker, SwiftShader's shaders) must not starve a motion of the
  // controller, which runs here without real-time priority.
  const host = await connectHost(wrc.hostPort);
  try {
    expect(await host.send('CONTROL')).toMatch(/^ACK/);
    expect(await (await host.job('HOME')).final).toMatch(/^INF/);
    expect(await (await host.job('MAP LP1')).final).toMatch(/^INF/);
    expect(await host.send('RELEASE')).toMatch(/^ACK/);
  } finally {
    host.close();
  }
  await page.setViewportSize({ width: 1280, height: 800 });
  await open(page, wrc.url);

  // The header: nothing cut off, the E-STOP wholly on screen.
  const header = await page.locator('header.app-header').evaluate((el) => ({ scroll: el.scrollWidth, client: el.clientWidth }));
  expect(header.scroll, 'the header fits').toBeLessThanOrEqual(header.client);
  const estop = await id('estop').boundingBox();
  expect(estop.x + estop.width, 'the E-STOP is on screen').toBeLessThanOrEqual(1280);

  // The Simulator: LP1's 25 wafers in one draw call, the stations named, the camera on the robot.
  await expect.poll(() => page.evaluate(() => Object.keys(window.wrc.sim.drawnWafers().slots).filter((k) => k.startsWith('LP1.')).length)).toBe(25);
  expect(await page.evaluate(() => window.wrc.sim.slotDrawCalls()), "LP1's wafers are instanced: one draw call").toBe(1);
  expect(await page.evaluate(() => window.wrc.sim.drawnIn()), 'drawn off the main thread').toBe('worker');
  await expect(page.locator('[data-testid="sim-label"][data-station="LP1"]')).toBeVisible();
  await expect(page.locator('[data-testid="sim-label"]')).toHaveCount(6);
  // At rest nothing is drawn: after 2 s of datagrams for the last changes to settle, the
  // frames counted do not move during 2 s more of datagrams.
  await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
  const framesAt = async () => page.evaluate(() => window.wrc.sim.framesDrawn());
  const lastSample = async () => page.evaluate(() => window.wrc.model.v.lastSample);
  const twoSeconds = async () => {
    const s0 = await lastSample();
    await expect.poll(lastSample, { message: 'datagrams keep coming' }).toBeGreaterThan(s0 + 2000);
  };
  await twoSeconds();
  const f0 = await framesAt();
  await twoSeconds();
  expect(await framesAt(), 'frames drawn at rest').toBe(f0);
  await shot(page, null, 'layout-1280-simulator.png');

  // The Wafers tab: every column fits, and the 3D view is beside it.
  await id('tab-wafers').click();
  const cols = await id('wafer-stations').evaluate((el) => ({ scroll: el.scrollWidth, client: el.clientWidth }));
  expect(cols.scroll, 'the Wafers columns fit').toBeLessThanOrEqual(cols.client);
  await expect(id('wafers-3d').locator('canvas')).toBeVisible();
  expect((await id('wafers-3d').boundingBox()).width).toBeGreaterThan(200);
  await shot(page, null, 'layout-1280-wafers.png');
  expect(pageErrors).toEqual([]);
});
