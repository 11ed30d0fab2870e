// The render worker: the 3D view's SceneHost on an OffscreenCanvas the page handed over, so
// that drawing (SwiftShader's work, on a PC without a graphics card) never holds up the page's
// main thread, where the E-STOP is handled. Messages in: `{ t: 'init', canvas, quality }`, then
// SceneMessages; out: SceneReports, or `{ t: 'failed', why }` when WebGL cannot start here.

import * as THREE from 'three';
import type { RenderQuality } from './scene';
import { SceneHost, type SceneMessage } from './scene-host';

let host: SceneHost | null = null;

self.onmessage = (ev: MessageEvent<{ t: 'init'; canvas: OffscreenCanvas; quality: RenderQuality } | SceneMessage>) => {
  const m = ev.data;
  if (m.t === 'init') {
    try {
      const renderer = new THREE.WebGLRenderer({ canvas: m.canvas, antialias: m.quality.antialias, powerPreference: 'low-power' });
      host = new SceneHost(renderer, m.quality, (r) => self.postMessage({ t: 'report', report: r }), (cb) =>
        self.requestAnimationFrame(cb),
      );
      self.postMessage({ t: 'ready' });
    } catch (e) {
      self.postMessage({ t: 'failed', why: String(e) });
    }
    return;
  }
  host?.handle(m);
};
