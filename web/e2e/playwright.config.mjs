// Playwright Test configuration of the GUI's end-to-end tests (gui.spec.mjs: an operator's session;
// editor.spec.mjs: the editor's compiler, debugger and points; recovery.spec.mjs: the recovery
// panel after a power loss cut a PUT; operator.spec.mjs: the E-STOP, the status line, disabled
// controls, other tabs, stored programs, the layout at 1280 × 800 and the 3D view at rest;
// contracts.spec.mjs: the controller's named signals, guarded outputs, refusals of motions that
// would touch the cell and RESET during a brake): Debian's Chromium
// (never a downloaded browser), one worker, and a trace and a screenshot of a failed run.
//
//   npm run e2e                       (from web/; builds nothing: run `npm run build` and
//                                      `cargo build -p wrc` first, the binary embeds web/dist)
//   WRC_BIN=/path/to/wrc              the binary (default: ../target/debug/wrc from web/)
//   WRC_TEST_OUTPUT=/dir              screenshots, the HTML report (report/) and a failed run's
//                                      trace (results/) (default: <repo>/test-output/gui/)
//   WRC_CHROMIUM=/usr/bin/chromium    the browser
//   WRC_E2E_HEADFUL=1                 show the browser (needs a display)
//   WRC_E2E_WEB_DIR=dist              serve this build (`wrc up --no-ui` + `wrc ui --web-dir`)
//                                      instead of the one embedded in the binary
//   WRC_E2E_STEP_MS, WRC_E2E_TOTAL_MS the longest wait for one thing and for the whole test
//
// A failed run: `npx playwright show-report <WRC_TEST_OUTPUT>/report`, or its trace with
// `npx playwright show-trace <WRC_TEST_OUTPUT>/results/<test>/trace.zip`.

import { defineConfig } from '@playwright/test';
import { CHROMIUM, OUT_DIR, STEP_MS, TOTAL_MS } from './settings.mjs';
import { join } from 'node:path';

export default defineConfig({
  testDir: '.',
  testMatch: '*.spec.mjs',
  // One controller, one page: the steps run in order, each on the state the last one left.
  workers: 1,
  fullyParallel: false,
  retries: 0,
  forbidOnly: true,
  timeout: TOTAL_MS,
  expect: { timeout: STEP_MS },
  outputDir: join(OUT_DIR, 'results'),
  reporter: [['list', { printSteps: true }], ['html', { outputFolder: join(OUT_DIR, 'report'), open: 'never' }]],
  use: {
    browserName: 'chromium',
    headless: !process.env.WRC_E2E_HEADFUL,
    launchOptions: {
      executablePath: CHROMIUM,
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
    },
    viewport: { width: 1600, height: 1000 },
    actionTimeout: STEP_MS,
    navigationTimeout: STEP_MS,
    // A failed run keeps its trace: every action with its timing and call log, the console and
    // the network. Without DOM snapshots and screencast: taking them at every action slows the
    // page (its WebGL canvas) down enough to miss the HOLD step's window on a loaded machine;
    // the failure's screenshot and page snapshot (error-context.md) show the end state.
    trace: { mode: 'retain-on-failure', snapshots: false, screenshots: false, sources: true },
    screenshot: 'only-on-failure',
  },
});
