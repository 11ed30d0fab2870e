// Coalescing of updates that arrive faster than the screen redraws (the simulator datagrams
// come every period): the controller model and the Wafers panel redraw once per frame.

/** Calls `fn` at most once per animation frame (or 16 ms without one). */
export function frameThrottle(fn: () => void): () => void {
  let queued = false;
  const raf: (cb: () => void) => void =
    typeof requestAnimationFrame === 'function'
      ? (cb) => requestAnimationFrame(() => cb())
      : (cb) => setTimeout(cb, 16);
  return () => {
    if (queued) return;
    queued = true;
    raf(() => {
      queued = false;
      fn();
    });
  };
}
