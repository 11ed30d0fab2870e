// The editor's debugger: the Run / Run paused / Step / Step over / Step out / Continue / Pause /
// Abort buttons (each enabled only when the controller would take it), breakpoints sent as
// `BREAK` when toggled and again before each run, the running program's line highlighted from
// `EVT PROGRAM` and the status stream's `line=`, and the operator's prompt of a `WAIT OPERATOR`.

import type { Bus } from '../protocol/bus';
import type { ControllerModel } from '../protocol/controller-model';
import type { ProgramTracker } from '../protocol/program-tracker';
import { h } from '../dom';
import { diagsFromEvents, isProgramName, programAbsLine, type Diag } from '../protocol/protocol';
import { breakpointEffect, breakpointLines, showDebugLine } from './debug-marks';
import { DEBUG_ACTIONS, enabledActions, locate, type DebugAction, type DebugState, type DebugView } from './debug-state';
import type { EditorHost } from './host';
import { parseAlarm } from './program-events';

/** An answer to `WAIT OPERATOR`: 1-32 letters, digits, `_` or `-`. */
export function answerOk(answer: string): boolean {
  return /^[A-Za-z0-9_-]{1,32}$/.test(answer);
}

/** The request of a debugger button (`run` and `runPaused` need the program's name). */
export function actionRequest(action: DebugAction, program: string, answer = ''): string {
  switch (action) {
    case 'run':
      return `RUN ${program}`;
    case 'runPaused':
      return `RUN ${program} STEP`;
    case 'step':
      return 'STEP';
    case 'stepOver':
      return 'STEP OVER';
    case 'stepOut':
      return 'STEP OUT';
    case 'continue':
      return answer ? `CONTINUE ${answer}` : 'CONTINUE';
    case 'pause':
      return 'PAUSE';
    case 'abort':
      return 'ABORT';
  }
}

const LABELS: Record<DebugAction, [string, string]> = {
  run: ['▶ Run', 'RUN: compile and store when edited, then run (F5)'],
  runPaused: ['▶❚ Run paused', 'RUN … STEP: start paused before the first statement'],
  step: ['Step', 'STEP: run one statement, into a called SUB (F11); its motions at 25 % speed at most'],
  stepOver: ['Step over', 'STEP OVER: run one statement, a CALL as a whole (F10)'],
  stepOut: ['Step out', 'STEP OUT: run to the end of the SUB or FUNCTION (Shift+F11)'],
  continue: ['Continue', 'CONTINUE: go on (with the answer, when the program waits for the operator)'],
  pause: ['❚❚ Pause', 'PAUSE: stop before the next statement (a motion under way finishes)'],
  abort: ['■ Abort', 'ABORT: end the program; its motion stops'],
};

const TEST_IDS: Record<DebugAction, string> = {
  run: 'editor-run',
  runPaused: 'editor-run-paused',
  step: 'editor-step',
  stepOver: 'editor-step-over',
  stepOut: 'editor-step-out',
  continue: 'editor-continue',
  pause: 'editor-pause',
  abort: 'editor-abort',
};

/** What the debugger asks of the editor. */
export interface DebuggerHooks {
  /** Store the buffer when the controller does not have it as it is; false: it could not. */
  ensureStored(): Promise<boolean>;
  /** Mark the line an ABS names (null: none). */
  markAbsLine(line: number | null): void;
  /** Show the diagnostics a RUN's reply carried. */
  showDiagnostics(diags: Diag[]): void;
  /** The program's state changed (not only its position). */
  stateChanged(v: DebugView): void;
}

export class ProgramDebugger {
  /** The debugger's buttons. */
  readonly toolbar: HTMLElement;
  /** `WAIT OPERATOR`'s prompt (hidden otherwise). */
  readonly prompt: HTMLElement;
  /** Where the program is (`line 12`, `in cell_lib line 30`). */
  readonly position: HTMLElement;
  /** The program's name and state. */
  readonly programState: HTMLElement;
  readonly state: DebugState;
  private readonly buttons = {} as Record<DebugAction, HTMLButtonElement>;
  private readonly promptText: HTMLElement;
  private readonly answer: HTMLInputElement;
  private readonly bus: Bus;

  /**
   * Breakpoints the controller has not been told (BREAK needs control: a page without it
   * keeps them until control is free or its own, then sends them).
   */
  private unsent = false;

  constructor(
    private readonly host: EditorHost,
    private readonly hooks: DebuggerHooks,
    tracker: ProgramTracker,
    private readonly model: Pick<ControllerModel, 'mayCommand' | 'onChange' | 'v'>,
  ) {
    this.bus = host.bus;
    this.state = tracker.state;
    for (const a of DEBUG_ACTIONS) {
      const [label, title] = LABELS[a];
      const cls = a === 'run' ? 'btn go' : a === 'abort' ? 'btn warn' : 'btn';
      this.buttons[a] = h('button', { class: cls, 'data-testid': TEST_IDS[a], title, onclick: () => void this.act(a) }, label);
    }
    this.toolbar = h(
      'div',
      { class: 'toolbar debug-bar' },
      this.buttons.run,
      this.buttons.runPaused,
      h('span', { class: 'sep' }),
      this.buttons.step,
      this.buttons.stepOver,
      this.buttons.stepOut,
      h('span', { class: 'sep' }),
      this.buttons.continue,
      this.buttons.pause,
      this.buttons.abort,
    );
    this.promptText = h('span', { class: 'operator-text', 'data-testid': 'operator-text' });
    this.answer = h('input', {
      type: 'text',
      class: 'operator-answer',
      'data-testid': 'operator-answer',
      maxlength: '32',
      spellcheck: 'false',
      placeholder: 'answer (optional)',
      'aria-label': 'Answer to the program',
    });
    this.answer.addEventListener('keydown', (e) => {
      if (e.key === 'Enter') void this.act('continue');
    });
    this.prompt = h(
      'div',
      { class: 'operator-prompt', 'data-testid': 'operator-prompt', role: 'alert', hidden: true },
      h('span', { class: 'operator-label' }, 'Operator:'),
      this.promptText,
      this.answer,
      h('button', { class: 'btn go', 'data-testid': 'operator-continue', onclick: () => void this.act('continue') }, 'Continue'),
    );
    this.position = h('span', { class: 'debug-position', 'data-testid': 'debug-position' });
    this.programState = h('span', { class: 'program-state', 'data-testid': 'program-state', 'data-state': 'none' });

    tracker.onChange((v, stateChanged, e) => {
      if (e) {
        const at = 'at' in e && e.at ? ` at ${e.at.file}:${e.at.line}` : '';
        this.host.say(`program ${e.name} ${e.state}${at}${e.state === 'WAITING' ? `: ${e.text}` : ''}`, 'info');
      }
      this.changed(stateChanged);
      void v;
    });
    this.bus.onEvent((name, body) => {
      if (name === 'ALARM') {
        const a = parseAlarm(body);
        if (a) this.host.say(`ALARM ${a.code} ${a.program} ${a.at ? `${a.at.file}:${a.at.line}` : ''}: ${a.text}`, 'err');
      }
    });
    // After each connection the breakpoints go once who holds control is known (BREAK needs
    // control: a tab without it keeps them quietly), and again whenever control comes free.
    this.bus.onConnection((up) => {
      if (up) this.unsent = true;
    });
    model.onChange(() => {
      if (this.unsent && this.ownerKnown() && model.mayCommand()) void this.syncBreakpoints(false);
    });
    this.changed(true);
  }

  /** The editor's program changed (another name or text): show where the program is anew. */
  refresh(): void {
    this.changed(false);
  }

  /** A click in the gutter set or cleared the breakpoint of `line`: tell the controller. */
  async toggled(line: number, on: boolean): Promise<void> {
    if (!this.bus.connected()) return;
    if (!this.ownerKnown() || !this.model.mayCommand()) {
      // Another source holds control: BREAK would be refused (120). Sent once it is free.
      this.unsent = true;
      this.host.setStatus('Breakpoint kept in the editor: another source holds control; it is sent when control is free.', 'info');
      return;
    }
    const request = on ? `BREAK ${line}` : `BREAK CLEAR ${line}`;
    try {
      const { first } = await this.bus.request(request);
      if (first.kind === 'NAK') {
        this.host.say(`${request}: NAK ${first.code} ${first.text}`, 'err');
        return;
      }
      // A running program stops at the next statement: the breakpoint moves there.
      const actual = Number(first.fields.line);
      if (on && Number.isInteger(actual) && actual !== line) {
        const view = this.host.view();
        view.dispatch({ effects: [breakpointEffect(view.state, line, false), breakpointEffect(view.state, actual, true)] });
      }
    } catch (e) {
      this.host.say(`${request}: ${e instanceof Error ? e.message : String(e)}`, 'err');
    }
  }

  /** Send the editor's breakpoints (after `BREAK CLEAR` when `clear`). */
  /** Whether this connection has been told who holds control. */
  private ownerKnown(): boolean {
    return this.bus.connected() && this.model.v.ownerEpoch === this.model.v.epoch && this.model.v.epoch > 0;
  }

  async syncBreakpoints(clear: boolean): Promise<void> {
    if (!this.bus.connected()) return;
    const lines = breakpointLines(this.host.view().state);
    if (!this.ownerKnown() || !this.model.mayCommand()) {
      // BREAK needs control: a tab without it keeps them quietly until control is free.
      this.unsent = lines.length > 0 || clear;
      return;
    }
    this.unsent = false;
    const requests = [...(clear ? ['BREAK CLEAR'] : []), ...lines.map((l) => `BREAK ${l}`)];
    for (const r of requests) {
      try {
        const { first } = await this.bus.request(r);
        if (first.kind === 'NAK') this.host.say(`${r}: NAK ${first.code} ${first.text}`, 'err');
      } catch {
        return; // the connection went: sent again when it is back
      }
    }
  }

  /** A button (or its key). */
  async act(action: DebugAction): Promise<void> {
    if (this.buttons[action].disabled) return;
    if (action === 'run' || action === 'runPaused') return this.run(action === 'runPaused');
    let answer = '';
    if (action === 'continue' && this.state.v.state === 'waiting') {
      answer = this.answer.value.trim();
      if (answer !== '' && !answerOk(answer)) {
        this.host.setStatus('An answer is 1-32 letters, digits, _ or -.', 'err');
        this.answer.focus();
        return;
      }
    }
    const request = actionRequest(action, this.host.program(), answer);
    this.host.say(`> ${request}`, 'info');
    try {
      const { first } = await this.bus.request(request);
      if (first.kind === 'ACK') {
        this.host.say(`ACK ${request}`, 'info');
        if (action === 'continue') this.answer.value = '';
      } else this.host.say(`NAK ${first.code} ${first.text}`, 'err');
    } catch (e) {
      this.host.say(`${request}: ${e instanceof Error ? e.message : String(e)}`, 'err');
    }
  }

  /** Store the program if needed, send the breakpoints, run it (paused: before its first
   * statement) and report its end. */
  private async run(paused: boolean): Promise<void> {
    const n = this.host.program();
    if (!isProgramName(n)) {
      this.host.setStatus('The program name must be 1-32 letters, digits, _ or -.', 'err');
      return;
    }
    if (!(await this.hooks.ensureStored())) return;
    this.hooks.markAbsLine(null);
    await this.syncBreakpoints(true);
    const request = actionRequest(paused ? 'runPaused' : 'run', n);
    this.host.say(`> ${request}`, 'info');
    let r: Awaited<ReturnType<Bus['request']>>;
    try {
      r = await this.bus.request(request);
    } catch (e) {
      this.host.say(`${request}: ${e instanceof Error ? e.message : String(e)}`, 'err');
      return;
    }
    const diags = diagsFromEvents(r.events);
    if (diags.length > 0) this.hooks.showDiagnostics(diags);
    if (r.first.kind === 'NAK') {
      this.host.say(`NAK ${r.first.code} ${r.first.text}`, 'err');
      this.host.setStatus(`RUN ${n} refused: ${r.first.code} ${r.first.text}`, 'err');
      return;
    }
    this.host.setStatus(`${n}: started${paused ? ' paused' : ''}`, 'ok');
    if (!r.final) return;
    try {
      const f = await r.final;
      if (f.kind === 'INF') {
        this.host.say(`INF program ${n} ended`, 'ok');
        this.host.setStatus(`${n}: program ended`, 'ok');
      } else {
        this.host.say(`ABS ${f.code} ${f.text}`, 'err');
        this.host.setStatus(`${n}: ended abnormally: ${f.code} ${f.text}`, 'err');
        // `<name> [<file> ]line <n>: …`: only a line of the program's own file is marked.
        const own = new RegExp(`^${n} line \\d+`).test(f.text);
        const line = programAbsLine(f.text);
        if (own && line !== null && this.host.program() === n) this.hooks.markAbsLine(line);
      }
    } catch (e) {
      this.host.say(`${request}: ${e instanceof Error ? e.message : String(e)}`, 'err');
    }
  }

  /** Draw the state: buttons, prompt, position and highlighted line. */
  private changed(stateChanged: boolean): void {
    const v = this.state.v;
    const on = enabledActions(v.state, this.bus.connected());
    for (const a of DEBUG_ACTIONS) this.buttons[a].disabled = !on[a];
    const where = locate(v, this.host.program());
    showDebugLine(this.host.view(), where.line);
    this.position.textContent = where.note;
    this.position.setAttribute('data-line', where.line === null ? '' : String(where.line));
    this.programState.textContent = v.state === 'none' ? '' : `${v.program ?? 'a program'}: ${v.state}`;
    this.programState.setAttribute('data-state', v.state);
    const waiting = v.state === 'waiting';
    if (this.prompt.hidden === waiting) {
      this.prompt.hidden = !waiting;
      if (waiting) this.answer.focus();
    }
    this.promptText.textContent = v.prompt ?? '';
    if (stateChanged) this.hooks.stateChanged(v);
  }
}
