// The DOM helpers every panel uses: one element builder (`h`) and writes that touch the DOM only
// when the value changed. Styles are in style sheets (style.css and a panel's own .css), never
// in strings.

/**
 * Attributes for `h`: a function is an event listener (`onclick`), `true` an empty attribute,
 * `false` and `undefined` leave the attribute out, `class` sets the class name.
 */
export type Attrs = Record<string, string | number | boolean | ((ev: Event) => void) | undefined>;

/** `h('button', { class: 'x', 'data-testid': 'go', onclick: fn }, 'Go')`. */
export function h<K extends keyof HTMLElementTagNameMap>(
  tag: K,
  attrs: Attrs = {},
  ...children: (Node | string | null | undefined)[]
): HTMLElementTagNameMap[K] {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === false) continue;
    if (typeof v === 'function') el.addEventListener(k.replace(/^on/, ''), v);
    else if (k === 'class') el.className = String(v);
    else if (v === true) el.setAttribute(k, '');
    else el.setAttribute(k, String(v));
  }
  for (const c of children) if (c !== null && c !== undefined) el.append(c);
  return el;
}

/** Set `el`'s text, leaving the DOM alone when it already reads `text`. */
export function setText(el: Element, text: string): void {
  if (el.textContent !== text) el.textContent = text;
}

/** Set an attribute, leaving the DOM alone when it already has `value`. */
export function setAttr(el: Element, name: string, value: string): void {
  if (el.getAttribute(name) !== value) el.setAttribute(name, value);
}
