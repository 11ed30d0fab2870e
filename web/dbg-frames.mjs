import { chromium } from '@playwright/test';
import { connectHost } from './e2e/host-client.mjs';
const b = await chromium.launch({ executablePath: '/usr/bin/chromium', args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-gpu'] });
const p = await b.newPage({ viewport: { width: 1600, height: 1000 } });
p.on('console', (m) => console.log('  page:', m.text()));
await p.addInitScript(() => {
  window.__long = [];
  new PerformanceObserver((l) => { for (const e of l.getEntries()) window.__long.push(Math.round(e.duration)); }).observe({ type: 'longtask' });
});
await p.goto('http://127.0.0.1:48080/');
await p.waitForFunction(() => window.wrc?.model?.v?.connected);
const h = await connectHost(47100);
await h.send('CONTROL');
await h.send('SPEED 30');
await (await h.job('HOME')).final;
await p.waitForTimeout(1500);
console.log('drawn in', await p.evaluate(() => window.wrc.sim.drawnIn()), JSON.stringify(await p.evaluate(() => window.wrc.sim.drawnPose())));
for (const target of ['MOVJ 0 90 -60 100', 'MOVJ -75 150 -75 0']) {
  await p.evaluate(() => { window.__long = []; });
  const f0 = await p.evaluate(() => window.wrc.sim.framesDrawn());
  const t0 = Date.now();
  const end = await (await h.job(target)).final;
  console.log(end, (Date.now() - t0) / 1000, 's, frames', await p.evaluate(() => window.wrc.sim.framesDrawn()) - f0, JSON.stringify(await p.evaluate(() => window.wrc.sim.frameTimes())), 'long tasks', JSON.stringify(await p.evaluate(() => window.__long)));
}
await p.screenshot({ path: '/tmp/dbg/shot.png' });
h.close();
await b.close();
