// End-to-end tests of the GUI's side of the controller's issue-39 lines (docs/gui.md): named
// and guarded signals (`EVT SIGNAL`), a guarded output switched only after a confirmation and
// then with FORCE (`NAK 141`, `EVT RECOVERY forced …`), a motion refused because it would
// touch a station (`NAK 117`), and a RESET during an E-stop's brake answered once the arm
// stands still. Each test first asks the controller for the line it needs and fails, saying
// which, when it does not have it.

import { expect, test } from './fixtures.mjs';
import { connectHost } from './host-client.mjs';
import { STEP_MS } from './settings.mjs';

const step = (title, body) => test.step(title, body, { timeout: 2 * STEP_MS });
/** Fail, naming `what`, unless the controller has it. */
function need(has, what) {
  if (!has) throw new Error(`the controller does not have ${what}`);
}

/** The controller's event lines of its ROBOT reply (`EVT SIGNAL …`). */
async function robotLines(port) {
  const host = await connectHost(port);
  const lines = [];
  const off = host.onLine((l) => lines.push(l));
  try {
    expect(await host.send('ROBOT')).toMatch(/^ACK/);
  } finally {
    off();
    host.close();
  }
  return lines;
}

async function open(page, url) {
  await page.goto(url);
  await expect(page.getByTestId('connection')).toHaveAttribute('data-connected', '1');
  await expect(page.getByTestId('current-axis-1')).toBeVisible();
}

test('signals are named from the configuration; a guarded output asks first, names the wafer, and is forced', async ({
  page,
  wrc,
  pageErrors,
}) => {
  const lines = await robotLines(wrc.hostPort);
  need(lines.some((l) => l.startsWith('EVT SIGNAL')), 'EVT SIGNAL lines (contract A)');
  const id = (t) => page.getByTestId(t);
  await open(page, wrc.url);

  await step('the Signals card names them, the guarded output marked', async () => {
    await expect(id('output-0')).toHaveAttribute('data-name', 'vacuum valve');
    await expect(id('output-0')).toHaveAttribute('data-guarded', '1');
    await expect(id('signal-out-0')).toContainText('guarded');
    await expect(id('input-14')).toHaveAttribute('data-name', 'interlock LP1 LP2');
    await expect(id('input-15')).toHaveAttribute('data-name', 'E-stop button');
  });

  await step('W4 on the hand: switching the vacuum valve off asks, naming it, and E-STOP works meanwhile', async () => {
    await id('take-control').click();
    await id('home').click();
    await expect(id('command-log')).toContainText('INF HOME');
    await id('raw-command').fill('MAP LP1');
    await id('raw-command').press('Enter');
    await expect(id('command-log')).toContainText('INF MAP finished');
    await id('raw-command').fill('GET LP1 4');
    await id('raw-command').press('Enter');
    await expect(id('command-log')).toContainText('INF GET finished: W4');
    await expect(id('output-0')).toHaveAttribute('data-on', '1');
    await id('output-0').click();
    await expect(id('confirm-dialog')).toBeVisible();
    await expect(id('confirm-title')).toHaveText('Switch off output 0 (vacuum valve)?');
    await expect(id('confirm-text')).toContainText('the hand holds W4: it will no longer be held and may drop');
    await expect(id('confirm-request')).toHaveText('OUT 0 0 FORCE');
    await id('estop').click();
    await expect(id('state')).toHaveAttribute('data-state', 'ESTOP');
    await id('confirm-cancel').click();
    await expect(id('command-log')).not.toContainText('OUT 0 0');
    await id('reset').click();
    await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
  });

  await step('confirmed: OUT 0 0 FORCE, the forced notice, and W4 uncertain on the hand', async () => {
    await id('output-0').click();
    await id('confirm-ok').click();
    await expect(id('command-log')).toContainText('ACK OUT');
    await expect
      .poll(() => page.evaluate(() => window.wrc.notices.notices().map((n) => n.tag)), { message: 'the forced output in the status line' })
      .toContain('FORCED');
    await id('tab-wafers').click();
    await expect(id('wafer-hand')).toHaveAttribute('data-uncertain', '1');
  });

  expect(pageErrors).toEqual([]);
});

test('a motion that would touch a station is refused in the status line (NAK 117)', async ({ page, wrc, pageErrors }) => {
  const id = (t) => page.getByTestId(t);
  await open(page, wrc.url);
  await id('take-control').click();
  await id('home').click();
  await expect(id('command-log')).toContainText('INF HOME');
  // The free move beside LP1: through its side.
  await id('mode-line').click();
  for (const [k, v] of Object.entries({ x: 250, y: -150, z: 100, yaw: 0 })) await id(`dest-${k}`).fill(String(v));
  await id('go').click();
  await expect(id('command-log')).toContainText(/NAK MOVL|INF MOVL|ACK MOVL/);
  const log = (await id('command-log').textContent()) ?? '';
  need(/NAK MOVL: 117/.test(log), 'NAK 117 (contract F)');
  await expect(id('status-tag')).toHaveText('NAK 117');
  await expect(id('status-text')).toContainText('(it would touch the cell)');
  expect(pageErrors).toEqual([]);
});

test('RESET during an E-stop brake waits for standstill instead of failing', async ({ page, wrc, pageErrors }) => {
  const id = (t) => page.getByTestId(t);
  await open(page, wrc.url);
  await id('take-control').click();
  await id('home').click();
  await expect(id('command-log')).toContainText('INF HOME');
  await id('mode-joint').click();
  for (const [k, v] of Object.entries({ j1: 150, j2: -120, j3: 200, j4: 250 })) await id(`dest-${k}`).fill(String(v));
  await id('go').click();
  await expect(id('state')).toHaveAttribute('data-state', 'MOVING');
  await id('estop').click();
  await id('reset').click();
  await expect(id('command-log')).toContainText(/(ACK|NAK) RESET/);
  const log = (await id('command-log').textContent()) ?? '';
  need(!/NAK RESET: 121/.test(log), 'a RESET answered at standstill (contract D)');
  await expect(id('state')).toHaveAttribute('data-state', 'IDLE');
  expect(await page.evaluate(() => window.wrc.notices.notices().filter((n) => n.level === 'refusal').length), 'refusals').toBe(0);
  expect(pageErrors).toEqual([]);
});
