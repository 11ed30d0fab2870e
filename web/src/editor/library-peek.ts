// A library's source while the program steps inside it: the debugger stands in `cell_lib`
// line 30, so the editor shows cell_lib (read-only, over the program's text) with that line
// highlighted and in view, and returns to the program when it runs in its own file again.
// **Show <program>** goes back earlier (until the program enters a library anew).

import { h, setText } from '../dom';
import type { ProgramTracker } from '../protocol/program-tracker';

/** A library's text, or why there is none. */
export type LibraryText = { text: string } | { text: null; why: string };

/** The file and line to show while stepping in a library of the editor's program; null: none. */
export function libraryPlace(
  v: ProgramTracker['v'],
  editorProgram: string,
): { file: string; line: number } | null {
  const p = v.position;
  if (v.state === 'none' || !p || v.program !== editorProgram || p.fileIndex === 0) return null;
  if (p.file === editorProgram) return null;
  return { file: p.file, line: p.line };
}

export class LibraryPeek {
  readonly el: HTMLElement;
  private readonly title: HTMLElement;
  private readonly body: HTMLElement;
  private readonly texts = new Map<string, string | null>();
  private shown: string | null = null;
  /** The operator went back to the program while the debugger was in this file. */
  private dismissed: string | null = null;

  constructor(
    private readonly editor: HTMLElement,
    private readonly tracker: ProgramTracker,
    private readonly program: () => string,
    private readonly read: (file: string) => Promise<LibraryText | { text: string; from: string }>,
  ) {
    this.title = h('span', { class: 'lib-peek-title', 'data-testid': 'library-title' });
    const back = h('button', { class: 'btn small', 'data-testid': 'library-back', onclick: () => this.back() }, '');
    this.body = h('div', { class: 'lib-peek-body', 'data-testid': 'library-source' });
    this.el = h('div', { class: 'lib-peek', 'data-testid': 'library-peek', hidden: true }, h('div', { class: 'lib-peek-bar' }, this.title, back), this.body);
    tracker.onChange(() => void this.update(back));
  }

  private back(): void {
    this.dismissed = this.shown;
    this.hide();
  }

  private hide(): void {
    this.shown = null;
    this.el.hidden = true;
    this.editor.hidden = false;
  }

  private async update(back: HTMLElement): Promise<void> {
    const at = libraryPlace(this.tracker.v, this.program());
    if (!at) {
      this.dismissed = null;
      this.hide();
      return;
    }
    if (this.dismissed === at.file) return;
    if (!this.texts.has(at.file)) {
      this.texts.set(at.file, null);
      const r = await this.read(at.file);
      this.texts.set(at.file, r.text);
      if (r.text === null) this.texts.set(at.file, `' ${at.file}: its source cannot be shown (${'why' in r ? r.why : 'unknown'}).`);
    }
    const text = this.texts.get(at.file);
    if (text === null || text === undefined) return; // still being read: the next change shows it
    const now = libraryPlace(this.tracker.v, this.program());
    if (!now || now.file !== at.file) return;
    if (this.shown !== at.file) {
      this.shown = at.file;
      this.body.replaceChildren(
        ...text.split('\n').map((l, i) =>
          h('div', { class: 'lib-line', 'data-line': String(i + 1) }, h('span', { class: 'lib-n' }, String(i + 1)), h('span', {}, l || ' ')),
        ),
      );
    }
    setText(this.title, `${at.file} — library, read-only: ${this.program()} is at line ${now.line}`);
    setText(back, `Show ${this.program()}`);
    for (const el of this.body.querySelectorAll('.lib-line.current')) el.classList.remove('current');
    const cur = this.body.querySelector<HTMLElement>(`.lib-line[data-line="${now.line}"]`);
    cur?.classList.add('current');
    this.el.setAttribute('data-line', String(now.line));
    this.editor.hidden = true;
    this.el.hidden = false;
    cur?.scrollIntoView({ block: 'center' });
  }
}
