import { defineConfig } from 'vitest/config';

// The app is served by `wrc ui` from web/dist (or embedded in the binary): relative asset
// paths, everything bundled (no CDN, no network fonts).
export default defineConfig({
  base: './',
  build: {
    outDir: 'dist',
    emptyOutDir: true,
    target: 'es2022',
    sourcemap: false,
    chunkSizeWarningLimit: 2000,
  },
  // The 3D view's render worker (view3d/scene-worker.ts) is an ES module worker.
  worker: { format: 'es' },
  server: {
    // `npm run dev` against a running `wrc ui` on :8080.
    proxy: {
      '/ws': { target: 'ws://127.0.0.1:8080', ws: true },
      '/api': { target: 'http://127.0.0.1:8080' },
    },
  },
  test: {
    include: ['src/**/*.test.ts'],
    environment: 'node',
  },
});
