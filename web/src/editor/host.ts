// What the Editor panel's parts (the debugger, the Debug pane, the Points panel) are given of
// the editor: the bus, the CodeMirror view, the program's name, the console and the status
// line. Types only.

import type { EditorView } from '@codemirror/view';
import type { Bus } from '../protocol/bus';

/** How a console line is shown. */
export type ConsoleKind = 'print' | 'info' | 'ok' | 'err';

export interface EditorHost {
  bus: Bus;
  /** The CodeMirror view. */
  view(): EditorView;
  /** The program's name as typed (trimmed; may not be a valid name). */
  program(): string;
  /** A console line. */
  say(text: string, kind?: ConsoleKind): void;
  /** The status line under the toolbar. */
  setStatus(message: string, kind?: 'ok' | 'err' | 'info'): void;
}
