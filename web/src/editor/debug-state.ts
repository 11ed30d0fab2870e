// The running program as the editor's debugger sees it, kept from `EVT PROGRAM` and the status
// stream's `line=`: its name, source files, state and position; which debugger buttons apply;
// and which editor line to highlight. Pure: no DOM, no bus; unit-tested.

import type { ProgramEvent } from './program-events';

/**
 * `none`: no program runs. `running`: it runs (`stepping`: one step of it). `paused`: it stands
 * before a statement (a breakpoint, a step's end, PAUSE). `waiting`: its `WAIT OPERATOR` waits
 * for CONTINUE.
 */
export type RunState = 'none' | 'running' | 'stepping' | 'paused' | 'waiting';

/** The debugger's buttons. */
export type DebugAction = 'run' | 'runPaused' | 'step' | 'stepOver' | 'stepOut' | 'continue' | 'pause' | 'abort';

export const DEBUG_ACTIONS: readonly DebugAction[] = ['run', 'runPaused', 'step', 'stepOver', 'stepOut', 'continue', 'pause', 'abort'];

/** Where the program is: the index of its source file (0: the program's own; null when the
 * file is not among those the run started with), the file's name and the line. */
export interface DebugPosition {
  fileIndex: number | null;
  file: string;
  line: number;
}

export interface DebugView {
  /** The running program's name (null: none, or one that started before this page knew). */
  program: string | null;
  state: RunState;
  /** Its source files: the program (0), then its libraries and called programs. */
  files: string[];
  position: DebugPosition | null;
  /** The operator's text of a `WAIT OPERATOR`. */
  prompt: string | null;
}

export class DebugState {
  readonly v: DebugView = { program: null, state: 'none', files: [], position: null, prompt: null };
  /**
   * A program ended: status lines still naming its line may follow the `ENDED` (the stream is
   * sent by another thread), so `line=` is not taken as a new program's until a status line
   * without one has come.
   */
  private ended = false;

  /** The connection went down (or came up): nothing is known of a program. */
  reset(): void {
    Object.assign(this.v, { program: null, state: 'none', files: [], position: null, prompt: null });
    this.ended = false;
  }

  /** An `EVT PROGRAM`; true when the view changed. */
  event(e: ProgramEvent): boolean {
    const v = this.v;
    switch (e.state) {
      case 'RUNNING':
        this.ended = false;
        if (e.files !== null) {
          // A run starts: its files, no position yet.
          v.files = e.files;
          v.position = null;
        } else if (v.program !== e.name) {
          v.files = [e.name];
        }
        v.program = e.name;
        v.state = e.step ? 'stepping' : 'running';
        v.prompt = null;
        return true;
      case 'PAUSED':
        this.adopt(e.name);
        v.state = 'paused';
        v.prompt = null;
        if (e.at) v.position = this.place(e.at.file, e.at.line);
        return true;
      case 'WAITING':
        this.adopt(e.name);
        v.state = 'waiting';
        v.prompt = e.text;
        if (e.at) v.position = this.place(e.at.file, e.at.line);
        return true;
      case 'ENDED':
        this.reset();
        this.ended = true;
        return true;
    }
  }

  /**
   * The status stream's `line=` (null: the line had none, so no program runs); true when the
   * view changed. A program the page did not see start is taken as running.
   */
  statusLine(at: { file: number; line: number } | null): boolean {
    const v = this.v;
    if (this.ended) {
      if (at === null) this.ended = false;
      return false;
    }
    if (at === null) {
      // Only a program the page never saw start can end without an `EVT PROGRAM ENDED`.
      if (v.state !== 'none' && v.program === null) {
        this.reset();
        return true;
      }
      return false;
    }
    if (v.state === 'none') v.state = 'running';
    const file = v.files[at.file] ?? (at.file === 0 && v.program ? v.program : `file ${at.file}`);
    const next: DebugPosition = { fileIndex: at.file, file, line: at.line };
    const p = v.position;
    if (p && p.fileIndex === next.fileIndex && p.line === next.line && p.file === next.file) return false;
    v.position = next;
    return true;
  }

  private adopt(name: string): void {
    if (this.v.program !== name) {
      this.v.program = name;
      this.v.files = [name];
    }
  }

  /** A position named by file (as events name it) and line. */
  private place(file: string, line: number): DebugPosition {
    const i = this.v.files.indexOf(file);
    return { fileIndex: i >= 0 ? i : file === this.v.program ? 0 : null, file, line };
  }
}

/** Which debugger buttons apply: with a connection, by the program's state. */
export function enabledActions(state: RunState, connected: boolean): Record<DebugAction, boolean> {
  const on = (...a: DebugAction[]): Record<DebugAction, boolean> =>
    Object.fromEntries(DEBUG_ACTIONS.map((x) => [x, connected && a.includes(x)])) as Record<DebugAction, boolean>;
  switch (state) {
    case 'none':
      return on('run', 'runPaused');
    case 'running':
    case 'stepping':
      return on('pause', 'abort');
    case 'paused':
      return on('step', 'stepOver', 'stepOut', 'continue', 'abort');
    case 'waiting':
      return on('continue', 'abort');
  }
}

/**
 * What the editor shows of the position when it holds program `editorProgram`: the line to
 * highlight (only in the program's own file, and only when it is the running program), and a
 * note for the status line (`line 12`, `in cell_lib line 30`, `other_prog line 4`).
 */
export function locate(v: DebugView, editorProgram: string): { line: number | null; note: string } {
  const p = v.position;
  if (v.state === 'none' || !p) return { line: null, note: '' };
  if (v.program === null) return { line: null, note: `a program started elsewhere: line ${p.line}` };
  if (v.program !== editorProgram) {
    return { line: null, note: `${v.program} ${p.fileIndex === 0 ? '' : `(${p.file}) `}line ${p.line}` };
  }
  if (p.fileIndex === 0) return { line: p.line, note: `line ${p.line}` };
  return { line: null, note: `in ${p.file} line ${p.line}` };
}
