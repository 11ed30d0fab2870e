// Small DOM helpers shared by the panels.

/** Add a `<style>` holding `css` to the page once, keyed by `id`; a no-op outside a browser. */
export function injectStyle(id: string, css: string): void {
  if (typeof document === 'undefined' || document.getElementById(id)) return;
  const s = document.createElement('style');
  s.id = id;
  s.textContent = css;
  document.head.appendChild(s);
}
