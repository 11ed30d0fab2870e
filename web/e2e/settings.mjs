// Where the end-to-end test finds the controller and the browser, where it writes, and how
// long it waits: from the environment (see playwright.config.mjs), with the defaults of a
// checkout where `make` built everything.

import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
/** web/ */
export const WEB_DIR = resolve(here, '..');
/** The repository. */
export const REPO = resolve(WEB_DIR, '..');
/** The `wrc` binary. */
export const WRC_BIN = resolve(WEB_DIR, process.env.WRC_BIN ?? '../target/debug/wrc');
/** Screenshots, the report and a failed run's trace. */
export const OUT_DIR = resolve(process.env.WRC_TEST_OUTPUT ?? join(REPO, 'test-output', 'gui'));
/** The browser: Debian's Chromium, never a downloaded one. */
export const CHROMIUM = process.env.WRC_CHROMIUM ?? '/usr/bin/chromium';
/** A build to serve with `wrc ui --web-dir` instead of the one embedded in the binary (null: none). */
export const SERVE_DIR = process.env.WRC_E2E_WEB_DIR ? resolve(WEB_DIR, process.env.WRC_E2E_WEB_DIR) : null;
/**
 * The longest wait for one thing [ms]. A step makes several such waits; on a loaded 2-core
 * machine the browser alone can take seconds per click, so a step as a whole gets twice that.
 */
export const STEP_MS = Number(process.env.WRC_E2E_STEP_MS ?? 30_000);
/** The longest the whole test may take, the controller's start included [ms]. */
export const TOTAL_MS = Number(process.env.WRC_E2E_TOTAL_MS ?? 480_000);
