// End-to-end tests of the Editor in real headless Chromium (fixtures.mjs): checking while typing
// with `wrc ui`'s compiler, completion and go-to-definition, the debugger (breakpoint, steps,
// watch, continue), the operator's prompt and alarms, the Points panel, and checking with the
// controller down. Each test has a `wrc up` (or a `wrc ui` alone) of its own; every wait waits
// for a condition (Playwright's expect), none for a time.

import { join } from 'node:path';
import { expect, newProgram, test } from './fixtures.mjs';
import { OUT_DIR, STEP_MS } from './settings.mjs';

const step = (title, body) => test.step(title, body, { timeout: 2 * STEP_MS });

/** Replace the editor's text, as typed (one input). */
async function setEditorText(page, text) {
  await page.locator('#panel-editor .cm-content').click();
  await page.keyboard.press('Control+A');
  await page.keyboard.press('Delete');
  await page.keyboard.insertText(text);
  await page.keyboard.press('Escape'); // a completion list the text opened
  const got = (await page.locator('#panel-editor .cm-line').allTextContents()).join('\n');
  expect(got.trim(), 'the editor holds the program').toBe(text.trim());
}

/** Open the page, wait for `connected` (or not), show the Editor and start a new program (New…). */
async function openEditor(page, url, program, { connected = true } = {}) {
  await page.goto(url);
  if (connected) await expect(page.getByTestId('connection')).toHaveAttribute('data-connected', '1');
  await page.getByTestId('tab-editor').click();
  await expect(page.locator('#panel-editor .cm-content')).toBeVisible();
  await newProgram(page, program);
}

/** The editor's line `n` [1-based]. */
const line = (page, n) => page.locator('#panel-editor .cm-line').nth(n - 1);

/** Click line `n`'s number: toggles its breakpoint. */
async function clickLineNumber(page, n) {
  await page.locator('#panel-editor .cm-lineNumbers .cm-gutterElement').filter({ hasText: new RegExp(`^${n}$`) }).click();
}

async function shot(page, file) {
  const path = join(OUT_DIR, file);
  await page.locator('#panel-editor').screenshot({ path });
  await test.info().attach(file, { path, contentType: 'image/png' });
}

test('the editor checks while typing with no program running: diagnostics, completion, go to definition', async ({
  page,
  wrc,
  pageErrors,
}) => {
  const id = (t) => page.getByTestId(t);
  await openEditor(page, wrc.url, 'e2e_check');

  await step('a program that compiles: no problems', async () => {
    await setEditorText(page, "' counting\nCOUNTER = 5\nPRINT COUNTER\n");
    await expect(id('check-state')).toHaveAttribute('data-state', 'ok');
    await expect(id('editor-problems')).toContainText('No problems.');
    await expect(id('program-state')).toHaveAttribute('data-state', 'none');
  });

  await step('typing an error shows it at its line and column', async () => {
    await page.locator('#panel-editor .cm-content').press('Control+End');
    await page.keyboard.insertText('PRINT TOTAL');
    await expect(id('check-state')).toHaveAttribute('data-state', 'errors');
    const problem = id('problem').first();
    await expect(problem).toHaveAttribute('data-line', '4');
    await expect(problem).toContainText('4:7');
    await expect(problem).toContainText('TOTAL');
    await expect(line(page, 4).locator('.cm-lintRange-error')).toHaveText('TOTAL');
    await shot(page, 'editor-live-error.png');
  });

  await step("completion offers the program's variable", async () => {
    await page.keyboard.press('Enter');
    await page.keyboard.type('PRINT COU');
    const list = page.locator('.cm-tooltip-autocomplete');
    await expect(list).toBeVisible();
    await expect(list.locator('li', { hasText: 'COUNTER' }).first()).toBeVisible();
    await page.keyboard.press('Escape');
  });

  await step('F12 and Ctrl-click go to the definition', async () => {
    // On COUNTER in line 3, F12 goes to line 2, where it is assigned.
    await line(page, 3).getByText('COUNTER').click();
    await page.keyboard.press('F12');
    await expect(page.locator('#panel-editor .cm-activeLine')).toHaveText('COUNTER = 5');
    await line(page, 3).getByText('COUNTER').click({ modifiers: ['Control'] });
    await expect(id('editor-status')).toContainText('COUNTER');
    await line(page, 4).getByText('PRINT').click({ modifiers: ['Control'] });
    await expect(id('editor-status')).toContainText('PRINT is part of the language');
  });

  expect(pageErrors).toEqual([]);
});

const DEBUG_PROGRAM = `' e2e debugger
SPEED 100
HOME
COUNT = 1
MOVEP POSE(260, 40, 5, 0)
COUNT = COUNT + 1
PRINT "count", COUNT
`;

test('the debugger: a breakpoint, the highlighted line, step over a motion, the watch, continue', async ({ page, wrc, pageErrors }) => {
  const id = (t) => page.getByTestId(t);
  await openEditor(page, wrc.url, 'e2e_debug');

  await step('a breakpoint on the motion and a watch on COUNT', async () => {
    await setEditorText(page, DEBUG_PROGRAM);
    await expect(id('check-state')).toHaveAttribute('data-state', 'ok');
    await clickLineNumber(page, 5);
    await expect(page.locator('#panel-editor .cm-breakpoint-dot')).toHaveCount(1);
    await id('watch-input').fill('COUNT');
    await id('watch-add').click();
    await expect(id('watch-row')).toHaveAttribute('data-name', 'COUNT');
  });

  await step('Run stops at the breakpoint with its line highlighted', async () => {
    await expect(id('editor-run')).toBeEnabled();
    await id('editor-run').click();
    await expect(id('program-state')).toHaveAttribute('data-state', 'paused');
    await expect(page.locator('#panel-editor .cm-line.cm-debug-line')).toHaveText('MOVEP POSE(260, 40, 5, 0)');
    await expect(id('debug-position')).toHaveText('line 5');
    await expect(id('watch-value')).toHaveText('1');
    await expect(id('variables').getByTestId('variable-row').filter({ hasText: 'COUNT' })).toContainText('1');
    await expect(id('editor-run')).toBeDisabled();
    await expect(id('editor-step-over')).toBeEnabled();
    await shot(page, 'editor-debug-paused.png');
  });

  await step('Step over runs the motion and stops at the next line', async () => {
    await id('editor-step-over').click();
    await expect(page.locator('#panel-editor .cm-line.cm-debug-line')).toHaveText('COUNT = COUNT + 1');
    await expect(id('program-state')).toHaveAttribute('data-state', 'paused');
    await expect(id('watch-value')).toHaveText('1');
  });

  await step('one more step: the watch shows the new value', async () => {
    await id('editor-step').click();
    await expect(page.locator('#panel-editor .cm-line.cm-debug-line')).toHaveText('PRINT "count", COUNT');
    await expect(id('watch-value')).toHaveText('2');
  });

  await step('Continue runs to the end', async () => {
    await id('editor-continue').click();
    await expect(id('console')).toContainText('count 2');
    await expect(id('console')).toContainText('INF program e2e_debug ended');
    await expect(id('program-state')).toHaveAttribute('data-state', 'none');
    await expect(page.locator('#panel-editor .cm-line.cm-debug-line')).toHaveCount(0);
    await expect(id('editor-run')).toBeEnabled();
  });

  expect(pageErrors).toEqual([]);
});

test("WAIT OPERATOR shows the prompt and goes on with the operator's answer; an ALARM shows in the header", async ({
  page,
  wrc,
  pageErrors,
}) => {
  const id = (t) => page.getByTestId(t);
  await openEditor(page, wrc.url, 'e2e_operator');

  await step('the program asks and waits', async () => {
    await setEditorText(
      page,
      'ALARM 1001, "vacuum low at LP1"\nWAIT OPERATOR "Load the cassette, then answer"\nPRINT "operator said", OPERATOR$\n',
    );
    await expect(id('check-state')).toHaveAttribute('data-state', 'ok');
    await id('editor-run').click();
    await expect(id('alarm')).toBeVisible();
    await expect(id('alarm-text')).toContainText('ALARM 1001');
    await expect(id('alarm-text')).toContainText('vacuum low at LP1');
    await expect(id('console')).toContainText('ALARM 1001');
    await expect(id('operator-prompt')).toBeVisible();
    await expect(id('operator-text')).toHaveText('Load the cassette, then answer');
    await expect(id('program-state')).toHaveAttribute('data-state', 'waiting');
    await expect(page.locator('#panel-editor .cm-line.cm-debug-line')).toHaveText(/^WAIT OPERATOR/);
    await shot(page, 'editor-operator.png');
  });

  await step('the answer goes with CONTINUE and the program prints it', async () => {
    await id('operator-answer').fill('cassette_ok');
    await id('operator-continue').click();
    await expect(id('console')).toContainText('operator said cassette_ok');
    await expect(id('console')).toContainText('INF program e2e_operator ended');
    await expect(id('operator-prompt')).toBeHidden();
    await id('alarm-dismiss').click();
    await expect(id('alarm')).toBeHidden();
  });

  expect(pageErrors).toEqual([]);
});

test('a point added in the Points panel is known to the compiler', async ({ page, wrc, pageErrors }) => {
  const id = (t) => page.getByTestId(t);
  await openEditor(page, wrc.url, 'e2e_points');

  await step('without the point, the program does not compile', async () => {
    await setEditorText(page, 'MOVEP SAFE\n');
    await expect(id('check-state')).toHaveAttribute('data-state', 'errors');
    await expect(id('problem').first()).toContainText('SAFE');
    await expect(id('points-panel')).toContainText('Points of e2e_points');
  });

  await step('add SAFE: it is listed and the program compiles', async () => {
    await id('point-new-name').fill('SAFE');
    await id('point-new-x').fill('260');
    await id('point-new-y').fill('40');
    await id('point-new-z').fill('10');
    await id('point-new-yaw').fill('0');
    await id('point-add').click();
    const row = page.locator('[data-testid="point-row"][data-name="SAFE"]');
    await expect(row).toBeVisible();
    await expect(row.getByTestId('point-y')).toHaveValue('40');
    await expect(id('check-state')).toHaveAttribute('data-state', 'ok');
    await expect(id('editor-problems')).toContainText('No problems.');
    await shot(page, 'editor-points.png');
  });

  await step('edit it, then delete it: the error comes back', async () => {
    const row = page.locator('[data-testid="point-row"][data-name="SAFE"]');
    await row.getByTestId('point-y').fill('50');
    await row.getByTestId('point-save').click();
    // Every connection hears the change (the test's own listener too).
    await expect.poll(() => wrc.events).toContain('EVT POINT e2e_points SAFE pose 260 50 10 0');
    await expect(id('points-hint')).toHaveText('');
    await row.getByTestId('point-delete').click();
    await expect(page.locator('[data-testid="point-row"][data-name="SAFE"]')).toHaveCount(0);
    await expect(id('check-state')).toHaveAttribute('data-state', 'errors');
  });

  expect(pageErrors).toEqual([]);
});

test('the editor checks programs with the controller down', async ({ page, lonelyUi }) => {
  const id = (t) => page.getByTestId(t);
  await openEditor(page, lonelyUi.url, 'e2e_offline', { connected: false });
  await expect(id('connection')).toHaveAttribute('data-connected', '0');
  await setEditorText(page, 'SPEED 50\nPRINT MISSING\n');
  await expect(id('check-state')).toHaveAttribute('data-state', 'errors');
  await expect(id('problem').first()).toHaveAttribute('data-line', '2');
  await expect(id('problem').first()).toContainText('MISSING');
  await expect(line(page, 2).locator('.cm-lintRange-error')).toHaveText('MISSING');
  await expect(id('editor-run')).toBeDisabled();
  await setEditorText(page, 'SPEED 50\nPRINT "fine"\n');
  await expect(id('check-state')).toHaveAttribute('data-state', 'ok');
});
