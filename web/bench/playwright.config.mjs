// The GUI benchmark (gui.bench.mjs): the end-to-end tests' configuration (Debian's Chromium
// with its software renderer, SwiftShader; one worker), run over the benchmark files instead.
//
//   npm run bench            (from web/; `npm run build` and `cargo build -p wrc` first)
//   BENCH_ESTOPS=40          E-STOP clicks measured (default 40)
//   BENCH_REST_S=20          the window the page's CPU at rest is measured over [s] (default 20)
//   BENCH_SEED=7             the seed of the moments of the clicks within each transfer
//   WRC_E2E_WEB_DIR=dist     measure that build (served by `wrc ui --web-dir`) instead of the
//                            one embedded in the binary; the other WRC_* settings as for e2e

import { defineConfig } from '@playwright/test';
import base from '../e2e/playwright.config.mjs';

export default defineConfig({
  ...base,
  testDir: '.',
  testMatch: '*.bench.mjs',
  reporter: [['list']],
  // Figures, not a pass/fail of timings: one long run.
  timeout: 60 * 60 * 1000,
});
