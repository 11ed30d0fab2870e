// The Points panel beside the editor: the named points of the program in the editor (`POINTS
// <program>`), each editable (x, y, z, yaw or joint values; Save sends `POINT`), taught where
// the robot is (`POINT … HERE`), deleted, and new ones added; kept in sync by `EVT POINT` from
// every connection and from the program's own TEACH. The points go with every compile.

import { h } from '../dom';
import { isProgramName } from '../protocol/protocol';
import type { EditorHost } from './host';
import { parsePoint, type PointEvent, type PointValue } from './program-events';
import {
  PointStore,
  pointDeleteRequest,
  pointHereRequest,
  pointNameOk,
  pointSetRequest,
  readNumbers,
  type NamedPoint,
} from './points';

const POSE_FIELDS = ['x', 'y', 'z', 'yaw'] as const;

/** The `EVT POINT` lines a `POINTS` reply collected (without `EVT `). */
function pointsOf(events: readonly string[]): PointEvent[] {
  const out: PointEvent[] = [];
  for (const e of events) {
    const m = /^POINT[ \t]+(.*)$/i.exec(e);
    const p = m ? parsePoint(m[1]) : null;
    if (p) out.push(p);
  }
  return out;
}

/** Joint values typed in one field: numbers separated by blanks or commas. */
function jointsText(text: string, axes: number): number[] | string {
  const parts = text.split(/[\s,]+/).filter((s) => s !== '');
  if (parts.length !== axes) return `give ${axes} joint values`;
  return readNumbers(parts.map((p, i) => ({ label: `joint ${i + 1}`, text: p })));
}

function fmt(v: number): string {
  return String(Math.round(v * 1000) / 1000);
}

export class PointsPanel {
  readonly el: HTMLElement;
  readonly store = new PointStore();
  private readonly title: HTMLElement;
  private readonly body: HTMLElement;
  private readonly hint: HTMLElement;
  private readonly newName: HTMLInputElement;
  private readonly newKind: HTMLSelectElement;
  private readonly newPose: HTMLInputElement[];
  private readonly newJoints: HTMLInputElement;
  private loaded = '';

  /** `changed()` is called whenever the points change (the editor compiles again). */
  constructor(
    private readonly host: EditorHost,
    private readonly changed: () => void,
  ) {
    this.title = h('span', {}, 'Points');
    this.body = h('div', { class: 'point-list', 'data-testid': 'points' });
    this.hint = h('div', { class: 'side-note', 'data-testid': 'points-hint' });
    this.newName = h('input', { type: 'text', 'data-testid': 'point-new-name', placeholder: 'NAME', maxlength: '32', spellcheck: 'false', 'aria-label': 'New point name' });
    this.newKind = h(
      'select',
      { 'data-testid': 'point-new-kind', 'aria-label': 'New point kind' },
      h('option', { value: 'pose' }, 'pose'),
      h('option', { value: 'joints' }, 'joints'),
    );
    this.newPose = POSE_FIELDS.map((f) => h('input', { type: 'text', class: 'num', 'data-testid': `point-new-${f}`, placeholder: f, 'aria-label': `New point ${f}` }));
    this.newJoints = h('input', { type: 'text', 'data-testid': 'point-new-joints', placeholder: 'j1 j2 j3 …', hidden: true, 'aria-label': 'New point joints' });
    this.newKind.addEventListener('change', () => {
      const joints = this.newKind.value === 'joints';
      for (const i of this.newPose) i.hidden = joints;
      this.newJoints.hidden = !joints;
    });
    this.el = h(
      'section',
      { class: 'side-section', 'data-testid': 'points-panel' },
      h('div', { class: 'pane-title' }, this.title, h('button', { class: 'btn small', 'data-testid': 'points-refresh', title: 'POINTS: read them again', onclick: () => void this.refresh() }, '⟳')),
      this.body,
      h(
        'div',
        { class: 'point-add' },
        h('div', { class: 'side-row' }, this.newName, this.newKind),
        h('div', { class: 'side-row' }, ...this.newPose, this.newJoints),
        h(
          'div',
          { class: 'side-row' },
          h('button', { class: 'btn small primary', 'data-testid': 'point-add', title: 'POINT: add it with these values', onclick: () => void this.add(false) }, 'Add'),
          h('button', { class: 'btn small', 'data-testid': 'point-add-here', title: 'POINT … HERE: add it where the robot is', onclick: () => void this.add(true) }, 'Add here'),
        ),
      ),
      this.hint,
    );
    host.bus.onEvent((name, body) => {
      if (name !== 'POINT') return;
      const p = parsePoint(body);
      if (p && this.store.apply(p)) {
        this.draw();
        this.changed();
      }
    });
    host.bus.onConnection((up) => {
      if (up) void this.refresh();
    });
    this.programChanged();
  }

  /** The editor's program name changed: its points. */
  programChanged(): void {
    const n = this.host.program();
    if (n === this.loaded) return;
    this.loaded = n;
    this.store.clear(isProgramName(n) ? n : '');
    this.title.textContent = isProgramName(n) ? `Points of ${n}` : 'Points';
    this.draw();
    this.changed();
    void this.refresh();
  }

  /** Ask `POINTS <program>`. */
  async refresh(): Promise<void> {
    const n = this.host.program();
    if (!isProgramName(n) || !this.host.bus.connected()) {
      this.say(this.host.bus.connected() ? '' : 'Not connected: the points are read from the controller.');
      return;
    }
    try {
      const { first, events } = await this.host.bus.request(`POINTS ${n}`);
      if (n !== this.host.program()) return; // another program meanwhile
      if (first.kind === 'NAK') return this.say(`POINTS: ${first.code} ${first.text}`);
      this.store.replaceAll(n, pointsOf(events));
      this.say('');
      this.draw();
      this.changed();
    } catch (e) {
      this.say(e instanceof Error ? e.message : String(e));
    }
  }

  /** Show point `name` (go to definition of a point). */
  highlight(name: string): void {
    for (const row of this.body.querySelectorAll('.point')) {
      const on = row.getAttribute('data-name')?.toUpperCase() === name.toUpperCase();
      row.classList.toggle('highlight', on);
      if (on) row.scrollIntoView({ block: 'nearest' });
    }
  }

  private axes(): number {
    return this.host.bus.robot()?.axes.length ?? 4;
  }

  private say(text: string): void {
    this.hint.textContent = text;
    this.hint.classList.toggle('err', text !== '');
  }

  /** Send a POINT request; its reply is shown in the hint line (the EVT POINT updates). */
  private async send(request: string): Promise<boolean> {
    if (!this.host.bus.connected()) {
      this.say('Not connected: points are stored by the controller.');
      return false;
    }
    try {
      const { first } = await this.host.bus.request(request);
      if (first.kind === 'NAK') {
        this.say(`${first.code} ${first.text}`);
        return false;
      }
      this.say('');
      return true;
    } catch (e) {
      this.say(e instanceof Error ? e.message : String(e));
      return false;
    }
  }

  private async add(here: boolean): Promise<void> {
    const program = this.host.program();
    if (!isProgramName(program)) return this.say('Give the program a name first.');
    const name = this.newName.value.trim();
    if (!pointNameOk(name)) return this.say('A point name is 1-32 letters, digits or _, starting with a letter or _.');
    let request: string;
    if (here) request = pointHereRequest(program, name);
    else {
      const value = this.typedValue(
        this.newKind.value === 'joints' ? 'joints' : 'pose',
        this.newPose.map((i) => i.value),
        this.newJoints.value,
      );
      if (typeof value === 'string') return this.say(value);
      request = pointSetRequest(program, name, value);
    }
    if (await this.send(request)) {
      this.newName.value = '';
      for (const i of [...this.newPose, this.newJoints]) i.value = '';
    }
  }

  /** A value from the panel's fields, or what is wrong with them. */
  private typedValue(kind: 'pose' | 'joints', pose: readonly string[], joints: string): PointValue | string {
    if (kind === 'joints') {
      const j = jointsText(joints, this.axes());
      return typeof j === 'string' ? j : { kind: 'joints', joints: j };
    }
    const v = readNumbers(POSE_FIELDS.map((label, i) => ({ label, text: pose[i] ?? '' })));
    return typeof v === 'string' ? v : { kind: 'pose', x: v[0], y: v[1], z: v[2], yaw: v[3] };
  }

  private row(p: NamedPoint): HTMLElement {
    const program = this.store.program;
    const inputs: HTMLInputElement[] =
      p.value.kind === 'pose'
        ? [p.value.x, p.value.y, p.value.z, p.value.yaw].map((v, i) =>
            h('input', { type: 'text', class: 'num', value: fmt(v), title: POSE_FIELDS[i], 'data-testid': `point-${POSE_FIELDS[i]}`, 'aria-label': `${p.name} ${POSE_FIELDS[i]}` }),
          )
        : [h('input', { type: 'text', value: p.value.joints.map(fmt).join(' '), 'data-testid': 'point-joints', title: 'joint values, separated by blanks', 'aria-label': `${p.name} joints` })];
    const save = async () => {
      const value = this.typedValue(
        p.value.kind,
        inputs.map((i) => i.value),
        inputs[0]?.value ?? '',
      );
      if (typeof value === 'string') return this.say(`${p.name}: ${value}`);
      await this.send(pointSetRequest(program, p.name, value));
    };
    for (const i of inputs) {
      i.addEventListener('keydown', (e) => {
        if (e.key === 'Enter') void save();
      });
    }
    return h(
      'div',
      { class: 'point', 'data-testid': 'point-row', 'data-name': p.name },
      h(
        'div',
        { class: 'side-row' },
        h('span', { class: 'var-name point-name' }, p.name),
        h('span', { class: 'point-kind' }, p.value.kind),
        h('span', { class: 'spacer' }),
        h('button', { class: 'btn small', 'data-testid': 'point-save', title: 'POINT: store these values', onclick: () => void save() }, 'Save'),
        h('button', { class: 'btn small', 'data-testid': 'point-here', title: 'POINT … HERE: store where the robot is', onclick: () => void this.send(pointHereRequest(program, p.name)) }, 'Teach here'),
        h('button', { class: 'btn small warn', 'data-testid': 'point-delete', title: 'POINT … DELETE', onclick: () => void this.send(pointDeleteRequest(program, p.name)) }, '✕'),
      ),
      h('div', { class: 'side-row point-values' }, ...inputs),
    );
  }

  private draw(): void {
    const list = this.store.list();
    this.body.replaceChildren(
      ...(list.length > 0
        ? list.map((p) => this.row(p))
        : [h('div', { class: 'side-note' }, this.store.program ? 'No points yet.' : 'Name the program to see its points.')]),
    );
  }
}
