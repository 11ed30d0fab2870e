// End-to-end test of the recovery panel in real headless Chromium against a real `wrc up`
// whose state directory holds a PUT LP2 1 of W1 that a power loss cut at the seat, before the
// release (recovery-fixture.mjs): the controller starts with W1 uncertain on the hand and in
// LP2 slot 1, the hand inside LP2 and alarm 216, and an operator recovers from the panel as
// the docs say — take control, reset, retract, home, sense the hand, map LP2 — until nothing
// is uncertain. Every wait is for a state or an event the page shows, never for a time.

import { mkdirSync } from 'node:fs';
import { join } from 'node:path';
import { expect, test } from './fixtures.mjs';
import { connectHost } from './host-client.mjs';
import { writeInterruptedPut } from './recovery-fixture.mjs';
import { OUT_DIR, STEP_MS } from './settings.mjs';

// (An object: Playwright would take a bare function for a fixture of its own.)
test.use({ wrcState: { write: writeInterruptedPut } });

/** Screenshot `selector` (the whole page when null) into WRC_TEST_OUTPUT, and attach it. */
async function shot(page, selector, file) {
  const path = join(OUT_DIR, file);
  if (selector) await page.locator(selector).screenshot({ path });
  else await page.screenshot({ path });
  await test.info().attach(file, { path, contentType: 'image/png' });
}

// A step makes several waits of up to STEP_MS each (see gui.spec.mjs).
const step = (title, body) => test.step(title, body, { timeout: 2 * STEP_MS });

/** The wafers the 3D view draws (null without WebGL, or before the robot is known). */
function drawnWafers(page) {
  return page.evaluate(() => {
    const d = window.wrc?.sim?.drawnWafers();
    return d && d.hand !== null ? d : null;
  });
}

test('recovery after a power loss cut a PUT: the panel, then control, reset, retract, home, sense and map from it', async ({
  page,
  wrc,
  pageErrors,
}) => {
  mkdirSync(OUT_DIR, { recursive: true });
  const id = (testId) => page.getByTestId(testId);
  const panel = id('recovery-panel');
  const dialog = id('recovery-dialog');
  const places = id('recovery-uncertain-place');

  /** Press a step's button, check what its dialog says will happen, and send it. */
  async function sendStep(stepId, says) {
    await expect(id(`recovery-step-${stepId}`)).toBeEnabled();
    await id(`recovery-step-${stepId}`).click();
    await expect(dialog).toBeVisible();
    await expect(id('recovery-dialog-text')).toContainText(says);
    await id('recovery-dialog-ok').click();
    await expect(dialog).toBeHidden();
  }

  /** Wait until the panel shows the end of `request` (INF, ABS or NAK), then check it is `INF …`. */
  async function endsWell(request, inf) {
    const esc = request.replace(/[.*+?^${}()|[\]\\]/g, '\\$&');
    await expect(id('recovery-result')).toHaveText(new RegExp(`^(INF ${esc} finished|(ABS|NAK) .*\\(${esc}\\)$)`));
    await expect(id('recovery-result')).toHaveText(inf);
  }

  await step('open the page: the banner, and the panel with what happened', async () => {
    await page.goto(wrc.url);
    await expect(id('connection')).toHaveAttribute('data-connected', '1');
    await expect(id('recovery-banner-text')).toHaveText('Recovery needed: 2 uncertain places · the hand may be inside LP2');
    await expect(panel, 'the panel opens by itself after such a restart').toBeVisible();
    await expect(id('recovery-note')).toContainText(
      'PUT LP2 1 (W1) was interrupted during step 5 (the approach and the straight line in); the vacuum is off, so its sensor cannot tell',
    );
    // Where the board's encoders stood: LP2 slot 1's seat, lifted (294.449, 170, 26, 30°).
    await expect(id('recovery-hand')).toHaveText(/^x=294\.4\d* y=170(\.\d+)? z=26(\.\d+)? yaw=30(\.\d+)?$/);
    await expect(id('recovery-inside')).toHaveText('may be inside LP2');
    await expect(id('recovery-inside')).toHaveAttribute('data-inside', '1');
    await expect(id('state')).toHaveAttribute('data-state', 'ERROR');
    await expect(id('header-error')).toContainText('216');
  });

  await step('the panel: the uncertain places, and the steps in order, control first', async () => {
    // One read of the whole list: on a loaded machine every expect costs a second or more.
    const list = await places.evaluateAll((els) => els.map((e) => `${e.getAttribute('data-place')} ${e.getAttribute('data-wafer')}`));
    expect(list).toEqual(['LP2.1 W1', 'hand W1']);
    const steps = page.locator('[data-testid="recovery-steps"] > li');
    await expect(steps).toHaveText([
      /^Take control/,
      /^Reset \(clears alarm 216\)take control first/,
      /^Retract out of LP2take control first/,
      /^Home \(out of LP2 first\)/,
      /^Sense the hand/,
      /^Map LP2/,
    ]);
    const enabled = await page
      .locator('[data-testid^="recovery-step-"], [data-testid="recovery-confirm"]')
      .evaluateAll((els) => els.map((e) => `${e.getAttribute('data-testid')}=${e.disabled ? 0 : 1}`));
    expect(enabled, 'only taking control may be pressed').toEqual([
      'recovery-step-control=1',
      'recovery-step-reset=0',
      'recovery-step-retract=0',
      'recovery-step-home=0',
      'recovery-step-sense-A=0',
      'recovery-step-map-LP2=0',
      'recovery-confirm=0',
    ]);
    await shot(page, null, 'recovery.png');
  });

  await step('3D view: both drawn apart as uncertain', async () => {
    // The page opens on it. Only the drawing is read here: on a loaded machine every action
    // while the 3D view draws is slow (software WebGL), so the operator's steps are taken on
    // the Wafers tab.
    await expect(id('tab-simulator')).toHaveAttribute('aria-selected', 'true');
    await expect
      .poll(async () => {
        const d = await drawnWafers(page);
        return d ? `${d.hand} ${d.slots['LP2.1']}` : 'no 3D view';
      })
      .toBe('uncertain uncertain');
  });

  await step('Wafers tab: W1? on the hand and in LP2 slot 1', async () => {
    await id('tab-wafers').click();
    await expect(id('wafer-slot-LP2-1')).toHaveAttribute('data-state', 'uncertain');
    await expect(id('wafer-slot-LP2-1')).toHaveText(/W1\?/);
    await expect(id('wafer-hand')).toHaveAttribute('data-uncertain', '1');
    await expect(id('wafer-hand')).toContainText('W1?');
    await shot(page, '#panel-wafers', 'recovery-wafers.png');
  });

  await step('✕ hides the panel; the banner stays and opens it again', async () => {
    await id('recovery-close').click();
    await expect(panel).toBeHidden();
    await expect(id('recovery-banner')).toBeVisible();
    await id('recovery-open').click();
    await expect(panel).toBeVisible();
  });

  await step('another source holds control: the panel says so rather than send what it would refuse', async () => {
    const host = await connectHost(wrc.hostPort);
    try {
      expect(await host.send('CONTROL')).toMatch(/^ACK 1 owner=tcp\d+/);
      await expect(id('recovery-why-control')).toHaveText(/^control is held by tcp\d+; it must release it first$/);
      await expect(id('recovery-step-control')).toBeDisabled();
      expect(await host.send('RELEASE')).toMatch(/^ACK 2 owner=none/);
      await expect(id('recovery-step-control')).toBeEnabled();
    } finally {
      host.close();
    }
  });

  await step('take control from the panel: RESET is next', async () => {
    // On the Wafers tab since its step: the operator watches the wafer map while recovering
    // (and the hidden 3D view does not draw: the page keeps up on a loaded machine).
    await expect(id('tab-wafers')).toHaveAttribute('aria-selected', 'true');
    await id('recovery-step-control').click();
    await expect(id('lock-owner')).toHaveAttribute('data-mine', '1');
    await expect(id('recovery-step-control'), 'the step is done').toHaveCount(0);
    await expect(id('recovery-step-reset')).toBeEnabled();
    await expect(id('recovery-why-retract')).toHaveText('the robot is in ERROR: RESET first');
  });

  await step('RESET alarm 216 from the panel: RETRACT is next; SENSE and MAP wait for it', async () => {
    await id('recovery-step-reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    await expect(id('recovery-step-reset')).toHaveCount(0);
    await expect(panel, 'reset clears the alarm, not the uncertainty').toBeVisible();
    await expect(id('recovery-step-retract')).toBeEnabled();
    await expect(id('recovery-why-retract')).toHaveText('← next');
    await expect(id('recovery-why-sense-A')).toHaveText('the hand may be inside LP2: RETRACT (or HOME) first');
    await expect(id('recovery-why-map-LP2')).toHaveText('the hand may be inside LP2: RETRACT (or HOME) first');
  });

  await step('another source stops the robot while a dialog is open: it is not sent, and says why', async () => {
    await id('recovery-step-retract').click();
    await expect(dialog).toBeVisible();
    await expect(id('recovery-dialog-request')).toHaveText('RETRACT');
    await expect(id('recovery-dialog-ok')).toBeEnabled();
    const host = await connectHost(wrc.hostPort);
    try {
      expect(await host.send('ESTOP')).toMatch(/^ACK 1/);
    } finally {
      host.close();
    }
    await expect(id('state')).toHaveAttribute('data-state', 'ESTOP');
    await expect(id('recovery-dialog-why')).toHaveText('Not sent now: the robot is in ESTOP: RESET first.');
    await expect(id('recovery-dialog-ok')).toBeDisabled();
    await id('recovery-dialog-cancel').click();
    await expect(dialog).toBeHidden();
    await expect(id('command-log')).not.toContainText('RETRACT');
    // RESET is offered again first.
    await expect(id('recovery-step-reset')).toBeEnabled();
    await id('recovery-step-reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    await expect(id('recovery-step-reset')).toHaveCount(0);
  });

  await step("the page's own E-STOP while the dialog is open: it is pressable and sends ESTOP", async () => {
    await id('recovery-step-retract').click();
    await expect(dialog).toBeVisible();
    // Playwright clicks only what receives the click: the dialog neither covers nor disables it.
    await id('estop').click();
    await expect(id('state')).toHaveAttribute('data-state', 'ESTOP');
    await expect(id('command-log')).toContainText('ACK ESTOP');
    await expect(id('recovery-dialog-why')).toHaveText('Not sent now: the robot is in ESTOP: RESET first.');
    await id('recovery-dialog-cancel').click();
    await expect(dialog).toBeHidden();
    await id('recovery-step-reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    await expect(id('recovery-step-reset')).toHaveCount(0);
  });

  await step('the confirmation dialog too: E-STOP sends ESTOP', async () => {
    await id('recovery-confirm-choice').selectOption('gone-W1');
    await id('recovery-confirm').click();
    await expect(dialog).toBeVisible();
    await id('estop').click();
    await expect(id('state')).toHaveAttribute('data-state', 'ESTOP');
    await id('recovery-dialog-cancel').click();
    await expect(dialog).toBeHidden();
    await id('recovery-step-reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
    await expect(id('command-log')).not.toContainText('CONFIRM');
  });

  await step('CONFIRM is offered with what it does; Cancel sends nothing', async () => {
    await id('recovery-confirm-choice').selectOption('gone-W1');
    await id('recovery-confirm').click();
    await expect(id('recovery-dialog-text')).toContainText(
      'CONFIRM W1 GONE removes W1 from the wafer map (it was perhaps at LP2 slot 1 or the hand)',
    );
    await expect(id('recovery-dialog-request')).toHaveText('CONFIRM W1 GONE');
    await id('recovery-dialog-cancel').click();
    await expect(dialog).toBeHidden();
    await expect(id('command-log')).not.toContainText('CONFIRM');
  });

  await step('RETRACT from the panel: the hand straight out of LP2', async () => {
    await sendStep('retract', "RETRACT: the hand moves straight out of LP2 along the station's line to its approach pose, at 20 %");
    await endsWell('RETRACT', /^INF RETRACT finished$/);
    await expect(id('recovery-done')).toContainText('retracted out of LP2');
    await expect(id('recovery-inside')).toHaveText('outside every station');
    await expect(id('recovery-step-retract'), 'out: the step is done').toHaveCount(0);
    await expect(id('recovery-banner-text')).toHaveText('Recovery needed: 2 uncertain places');
    await expect(id('recovery-why-sense-A')).toHaveText('the robot is not homed: HOME first');
  });

  await step('HOME from the panel', async () => {
    await sendStep('home', 'HOME: every axis goes to its home position by a PTP move, slowly (at most 20 %');
    await endsWell('HOME', /^INF HOME finished$/);
    await expect(id('recovery-step-home'), 'homed: the step is done').toHaveCount(0);
  });

  await step('SENSE the hand: empty, so W1 stays uncertain only in LP2 slot 1', async () => {
    await sendStep('sense-A', 'the hand’s vacuum is switched on and its sensor read; the robot does not move');
    await endsWell('SENSE', /^INF SENSE finished: none$/);
    await expect(id('recovery-done')).toContainText('SENSE: W1 is not on the hand (vacuum sensor)');
    await expect(id('recovery-banner-text')).toHaveText('Recovery needed: 1 uncertain place');
    await expect(places).toHaveCount(1);
    await expect(places).toHaveAttribute('data-place', 'LP2.1');
  });

  await step('MAP LP2: the wafer is found, nothing is uncertain, the panel goes', async () => {
    await sendStep('map-LP2', "MAP LP2: the hand moves by PTP to LP2's approach pose below slot 1 (outside the station)");
    // The panel goes with the last uncertain place: the command log keeps the reply.
    await expect(id('command-log')).toContainText('INF MAP finished: LP2 1000000000000000000000000');
    await expect(id('recovery-banner')).toBeHidden();
    await expect(panel).toBeHidden();
  });

  await step('Wafers tab: W1 in LP2 slot 1, the hand empty, no "?" anywhere', async () => {
    await expect(id('wafer-slot-LP2-1')).toHaveAttribute('data-state', 'wafer');
    await expect(id('wafer-hand')).toHaveAttribute('data-wafer', '');
    const shown = await page.locator('#panel-wafers').evaluate((el) => ({
      uncertain: el.querySelectorAll('[data-state="uncertain"], [data-uncertain="1"]').length,
      text: el.querySelector('[data-testid="wafer-stations"]')?.textContent ?? '',
      hand: el.querySelector('[data-testid="wafer-hand"]')?.textContent ?? '',
    }));
    expect(shown.uncertain, 'places drawn uncertain').toBe(0);
    expect(`${shown.text} ${shown.hand}`, 'no wafer shown with a "?"').not.toMatch(/W\d+\?/);
    await shot(page, '#panel-wafers', 'recovery-done.png');
  });

  await step('3D view: W1 drawn as a wafer in LP2 slot 1, the hand empty', async () => {
    await id('tab-simulator').click();
    await expect
      .poll(async () => {
        const d = await drawnWafers(page);
        return d ? `${d.hand} ${d.slots['LP2.1']}` : 'no 3D view';
      })
      .toBe('none wafer');
  });

  expect(pageErrors, 'errors in the page').toEqual([]);
});
