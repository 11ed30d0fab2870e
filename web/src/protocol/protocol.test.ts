import { describe, expect, it } from 'vitest';
import {
  IdAllocator,
  completesLater,
  diagsFromEvents,
  errorText,
  fmtNum,
  formatRequest,
  formatUpload,
  isProgramName,
  parseAxis,
  parseDiag,
  parseErrorEvent,
  parseFields,
  parseInputEvent,
  parseIo,
  parseLine,
  parseProgramEvent,
  parsePrograms,
  parseState,
  parseStatus,
  programAbsLine,
  replyRest,
  parseSignal,
  robotFromReply,
  traceSaveOutcome,
  traceSaveRequest,
  verbOf,
} from './protocol';
import type { FirstReply } from './bus';

describe('parseLine', () => {
  it('parses ACK with id and fields', () => {
    expect(parseLine('ACK 1 state=IDLE homed=0 speed=100 owner=none err=0')).toEqual({
      kind: 'ACK',
      id: 1,
      fields: { state: 'IDLE', homed: '0', speed: '100', owner: 'none', err: '0' },
      line: 'ACK 1 state=IDLE homed=0 speed=100 owner=none err=0',
    });
  });

  it('parses ACK without id', () => {
    const l = parseLine('ACK speed=50');
    expect(l).toMatchObject({ kind: 'ACK', id: null, fields: { speed: '50' } });
    expect(parseLine('ACK')).toMatchObject({ kind: 'ACK', id: null, fields: {} });
    expect(parseLine('ACK 3')).toMatchObject({ kind: 'ACK', id: 3, fields: {} });
  });

  it('compares ids as numbers', () => {
    expect(parseLine('ACK 007')).toMatchObject({ id: 7 });
  });

  it('tells NAK <id> <code> from NAK <code>', () => {
    expect(parseLine('NAK 2 110 not homed; send HOME first')).toMatchObject({
      kind: 'NAK',
      id: 2,
      code: 110,
      text: 'not homed; send HOME first',
    });
    expect(parseLine('NAK 103 line of 300 bytes is longer than the limit of 256 bytes; nothing was done')).toMatchObject({
      kind: 'NAK',
      id: null,
      code: 103,
    });
  });

  it('parses INF and ABS', () => {
    expect(parseLine('INF 3')).toMatchObject({ kind: 'INF', id: 3, fields: {} });
    expect(parseLine('ABS 5 200 stopped by STOP')).toMatchObject({ kind: 'ABS', id: 5, code: 200, text: 'stopped by STOP' });
    expect(parseLine('ABS 2 210 demo line 4: division by zero')).toMatchObject({ code: 210, text: 'demo line 4: division by zero' });
  });

  it('parses events with upper-case names and the rest as body', () => {
    expect(parseLine('EVT STATE MOVING')).toEqual({ kind: 'EVT', name: 'STATE', body: 'MOVING', line: 'EVT STATE MOVING' });
    expect(parseLine('EVT STATE HELD')).toEqual({ kind: 'EVT', name: 'STATE', body: 'HELD', line: 'EVT STATE HELD' });
    expect(parseLine('EVT PRINT  two  spaces kept')).toMatchObject({ name: 'PRINT', body: 'two  spaces kept' });
    expect(parseLine('EVT UI CONNECTED /tmp/wrc/wrc.sock')).toMatchObject({ name: 'UI', body: 'CONNECTED /tmp/wrc/wrc.sock' });
    expect(parseLine('EVT CONTROL')).toMatchObject({ name: 'CONTROL', body: '' });
  });

  it('drops a serial checksum and a trailing CR', () => {
    expect(parseLine('ACK 1 state=IDLE homed=1 speed=100 owner=none err=0*04')).toMatchObject({ fields: { err: '0' } });
    expect(parseLine('INF 4\r')).toMatchObject({ kind: 'INF', id: 4 });
  });

  it('classifies anything else as OTHER', () => {
    expect(parseLine('hello')).toMatchObject({ kind: 'OTHER' });
    expect(parseLine('')).toMatchObject({ kind: 'OTHER' });
  });
});

describe('fields, status, io', () => {
  it('parses key=value pairs', () => {
    expect(parseFields('a=1 b= c=x=y plain')).toEqual({ a: '1', b: '', c: 'x=y' });
  });

  it('parses EVT STATUS', () => {
    const s = parseStatus(
      'state=MOVING homed=1 speed=50 owner=unix err=0 j=10,45.5,-45.5,5 x=310.243 y=199.555 z=5 yaw=10',
    );
    expect(s).toEqual({
      state: 'MOVING',
      homed: true,
      speed: 50,
      owner: 'unix',
      err: 0,
      joints: [10, 45.5, -45.5, 5],
      x: 310.243,
      y: 199.555,
      z: 5,
      yaw: 10,
    });
  });

  it('knows all six states, HELD among them', () => {
    for (const st of ['IDLE', 'MOVING', 'STOPPING', 'HELD', 'ERROR', 'ESTOP']) {
      expect(parseState(st), st).toBe(st);
    }
    expect(parseState(' held ')).toBe('HELD');
    expect(parseState('HOLD')).toBeNull();
    expect(parseState(undefined)).toBeNull();
  });

  it('parses a STATUS reply of a held motion', () => {
    const l = parseLine('ACK 9 state=HELD homed=1 speed=40 owner=gui0 err=0');
    if (l.kind !== 'ACK') throw new Error('not an ACK');
    expect(parseStatus(l.fields)).toEqual({ state: 'HELD', homed: true, speed: 40, owner: 'gui0', err: 0 });
    expect(parseStatus('state=HELD homed=1 speed=40 owner=none err=0').state).toBe('HELD');
  });

  it('parses WHERE fields and ignores an unknown state', () => {
    expect(parseStatus({ j: '0,45,-45,5', x: '341.421', y: '141.421', z: '5', yaw: '0' })).toEqual({
      joints: [0, 45, -45, 5],
      x: 341.421,
      y: 141.421,
      z: 5,
      yaw: 0,
    });
    expect(parseStatus('state=DANCING').state).toBeUndefined();
  });

  it('parses IO words', () => {
    expect(parseIo({ in: '00000001', out: '80000008' })).toEqual({ inputs: 1, outputs: 0x80000008 });
    expect(parseIo({ in: '1' })).toBeNull();
  });

  it('parses INPUT, ERROR, PROGRAM events and PROGRAMS', () => {
    expect(parseInputEvent('3 1')).toEqual({ n: 3, on: true });
    expect(parseInputEvent('3 x')).toBeNull();
    expect(parseErrorEvent('203 following error on axis j2')).toEqual({ code: 203, text: 'following error on axis j2' });
    expect(parseProgramEvent('demo RUNNING')).toEqual({ name: 'demo', state: 'RUNNING' });
    expect(parsePrograms({ programs: 'a,b-2,c_3' })).toEqual(['a', 'b-2', 'c_3']);
    expect(parsePrograms({ programs: '' })).toEqual([]);
    expect(parsePrograms({})).toEqual([]);
  });

  it('names error codes', () => {
    expect(errorText(0)).toBe('');
    expect(errorText(201)).toBe('201 emergency stop');
    expect(errorText(213)).toBe('213 wafer lost');
    expect(errorText(299)).toBe('299 error');
  });

  it('gives what an INF says after its id (GET names the wafer, MAP the slots)', () => {
    expect(replyRest('INF 3 W3')).toBe('W3');
    expect(replyRest('INF 7 LP1 1111111111111111111111111')).toBe('LP1 1111111111111111111111111');
    expect(replyRest('INF 3')).toBe('');
    expect(replyRest('INF W3')).toBe('W3');
    expect(replyRest('ACK 4 owner=gui0*1F')).toBe('owner=gui0');
  });
});

describe('robot', () => {
  const events = [
    'AXIS 2 name=j2 role=elbow unit=deg ppu=1000 min=-165 max=165 home=150',
    'AXIS 1 name=j1 role=shoulder unit=deg ppu=1000 min=-180 max=180 home=-75',
    'STATE IDLE',
    'AXIS 3 name=j3 role=wrist unit=deg ppu=1000 min=-270 max=270 home=-75',
    'AXIS 4 name=z role=z unit=mm ppu=1000 min=0 max=300 home=0',
  ];
  const ack = parseLine('ACK 1 name=paper-300mm link1=200 link2=200 hand=0 axes=4 period_ms=10 inputs=32 outputs=32');

  it('parses one axis', () => {
    expect(parseAxis('4 name=z role=z unit=mm ppu=1000 min=0 max=300 home=0')).toEqual({
      index: 4,
      name: 'z',
      role: 'z',
      unit: 'mm',
      ppu: 1000,
      min: 0,
      max: 300,
      home: 0,
    });
    expect(parseAxis('name=z')).toBeNull();
  });

  it('builds RobotInfo from the ROBOT reply, axes in order', () => {
    if (ack.kind !== 'ACK') throw new Error('not an ACK');
    const r = robotFromReply(ack.fields, events);
    expect(r).toMatchObject({ name: 'paper-300mm', link1: 200, link2: 200, hand: 0, periodMs: 10, inputs: 32, outputs: 32 });
    expect(r.axes.map((a) => a.name)).toEqual(['j1', 'j2', 'j3', 'z']);
    expect(r.axes[0].home).toBe(-75);
    expect(r.bladeB).toBeNull(); // no blade_b=: a single hand
  });

  it('reads blade B of a dual-blade robot from blade_b=', () => {
    const dual = parseLine(
      'ACK 1 name=paper-dual link1=200 link2=200 hand=0 axes=4 period_ms=10 inputs=32 outputs=32 blade_b=-30',
    );
    if (dual.kind !== 'ACK') throw new Error('not an ACK');
    const r = robotFromReply(dual.fields, events);
    expect(r).toMatchObject({ name: 'paper-dual', hand: 0, bladeB: -30 });
    expect(r.axes).toHaveLength(4);
    expect(robotFromReply({ ...dual.fields, blade_b: '12.5' }, []).bladeB).toBe(12.5);
    expect(robotFromReply({ ...dual.fields, blade_b: '0' }, []).bladeB).toBe(0); // stacked level: still two blades
    // A garbled value draws no blade rather than one at a made-up height.
    for (const bad of ['', 'x', 'NaN', 'Infinity']) {
      expect(robotFromReply({ ...dual.fields, blade_b: bad }, []).bladeB, bad).toBeNull();
    }
  });
});

describe('diagnostics', () => {
  it('parses EVT DIAG bodies', () => {
    expect(parseDiag('demo.wrl:3:7: error: unknown name TOTAL')).toEqual({
      file: 'demo.wrl',
      line: 3,
      col: 7,
      severity: 'error',
      message: 'unknown name TOTAL',
    });
    expect(parseDiag('DIAG x.wrl:12:1: warning: variable N is assigned but never read: a: b')).toMatchObject({
      line: 12,
      col: 1,
      severity: 'warning',
      message: 'variable N is assigned but never read: a: b',
    });
    expect(parseDiag('garbage')).toBeNull();
  });

  it('collects only DIAG lines among events', () => {
    const d = diagsFromEvents(['STATE IDLE', 'DIAG p.wrl:1:1: error: a', 'DIAG p.wrl:2:5: warning: b']);
    expect(d.map((x) => [x.line, x.col, x.severity])).toEqual([
      [1, 1, 'error'],
      [2, 5, 'warning'],
    ]);
  });

  it('finds the line an ABS names', () => {
    expect(programAbsLine('demo line 4: division by zero')).toBe(4);
    expect(programAbsLine('emergency stop')).toBeNull();
  });
});

describe('requests', () => {
  it('allocates ids 1..99999999 and wraps', () => {
    const a = new IdAllocator();
    expect([a.next(), a.next(), a.next()]).toEqual([1, 2, 3]);
    const b = new IdAllocator(99_999_998);
    expect([b.next(), b.next()]).toEqual([99_999_999, 1]);
  });

  it('formats requests and knows the verbs that complete later', () => {
    expect(formatRequest(7, ' MOVP 1 2 3 4 ')).toBe('7 MOVP 1 2 3 4');
    expect(verbOf('12 movj 1 2 3 4')).toBe('MOVJ');
    for (const v of ['HOME', 'movj 1', 'MOVP 1', 'MOVL 1', 'JOG 1 100', 'WAIT', 'RUN x', 'GET LP1 3', 'put LP1 3', 'GET PM1 1 B', 'PUT PM1 1 A', 'SWAP PM1 1', '9 swap PM1 1', 'MAP LP1', 'RETRACT', 'SENSE', 'sense B']) {
      expect(completesLater(v), v).toBe(true);
    }
    // HOLD and RESUME answer ACK only: the held motion's own request ends with INF/ABS.
    for (const v of ['STATUS', 'STOP', 'ESTOP', 'HOLD', 'RESUME', 'SPEED 5', 'OUT 1 1', 'UPLOAD x', 'CONTROL', 'WAFERS', 'STN', 'TEACH LP1', 'RECOVERY', 'CONFIRM W1 GONE']) {
      expect(completesLater(v), v).toBe(false);
    }
  });

  it('formats an upload and refuses a lone dot', () => {
    expect(formatUpload(1, 'demo', 'HOME\r\nPRINT "done"\n')).toBe('1 UPLOAD demo\nHOME\nPRINT "done"\n.');
    expect(formatUpload(2, 'e', '')).toBe('2 UPLOAD e\n.');
    expect(() => formatUpload(3, 'x', 'HOME\n.\nHOME')).toThrow(/line 2/);
  });

  it('checks program names', () => {
    expect(isProgramName('pick_place-2')).toBe(true);
    expect(isProgramName('')).toBe(false);
    expect(isProgramName('a b')).toBe(false);
    expect(isProgramName('x'.repeat(33))).toBe(false);
  });

  it('formats numbers like the protocol', () => {
    expect(fmtNum(250)).toBe('250');
    expect(fmtNum(-45.1234)).toBe('-45.123');
    expect(fmtNum(12.5)).toBe('12.5');
    expect(fmtNum(-0.0001)).toBe('0');
  });
});

describe('TRACE SAVE', () => {
  /** The first reply as the connection makes it from a controller line. */
  function first(line: string): FirstReply {
    const l = parseLine(line);
    if (l.kind === 'ACK') return { kind: 'ACK', id: l.id ?? 0, fields: l.fields, line: l.line };
    if (l.kind === 'NAK') return { kind: 'NAK', id: l.id ?? 0, code: l.code, text: l.text, line: l.line };
    throw new Error(`not a first reply: ${line}`);
  }

  it('names the trace only when asked, and refuses a name the controller would', () => {
    expect(traceSaveRequest('')).toBe('TRACE SAVE');
    expect(traceSaveRequest('  ')).toBe('TRACE SAVE');
    expect(traceSaveRequest(' before_alarm-2 ')).toBe('TRACE SAVE before_alarm-2');
    expect(verbOf(traceSaveRequest('x'))).toBe('TRACE');
    expect(completesLater('TRACE SAVE')).toBe(false);
    for (const bad of ['a b', 'x'.repeat(33), '../etc', 'a.wrctrace']) {
      expect(() => traceSaveRequest(bad), bad).toThrow(/must be 1-32 letters, digits, _ or -/);
    }
  });

  it('reads the file, counts and seconds of the ACK', () => {
    expect(traceSaveOutcome(first('ACK 12 file=/var/lib/wrc/traces/t1.wrctrace samples=3000 messages=41 seconds=29.99'))).toEqual({
      ok: true,
      saved: { file: '/var/lib/wrc/traces/t1.wrctrace', samples: 3000, messages: 41, seconds: 29.99 },
    });
    // Fields in another order, and a path with blanks.
    expect(traceSaveOutcome(first('ACK 3 samples=1 file=/tmp/my traces/a b.wrctrace seconds=0.01 messages=0'))).toEqual({
      ok: true,
      saved: { file: '/tmp/my traces/a b.wrctrace', samples: 1, messages: 0, seconds: 0.01 },
    });
    expect(traceSaveOutcome(first('ACK 4 file=/t/x.wrctrace'))).toEqual({
      ok: true,
      saved: { file: '/t/x.wrctrace', samples: null, messages: null, seconds: null },
    });
  });

  it('gives the NAK text, and says so when an ACK names no file', () => {
    expect(traceSaveOutcome(first('NAK 5 104 trace name "a b" must be 1-32 letters, digits, _ or -'))).toEqual({
      ok: false,
      text: '104 trace name "a b" must be 1-32 letters, digits, _ or -',
    });
    expect(traceSaveOutcome(first('NAK 6 100 unknown verb TRACE'))).toEqual({ ok: false, text: '100 unknown verb TRACE' });
    expect(traceSaveOutcome(first('ACK 7 samples=3'))).toEqual({
      ok: false,
      text: "the controller's reply names no file: ACK 7 samples=3",
    });
    expect(traceSaveOutcome(first('ACK 8 file='))).toMatchObject({ ok: false });
  });
});

describe('named signals (EVT SIGNAL lines of the ROBOT reply)', () => {
  const lines = [
    'SIGNAL out 0 guarded vacuum valve',
    'SIGNAL out 1 - mapping sensor',
    'SIGNAL in 0 - vacuum sensor',
    'SIGNAL in 14 - interlock LP1 LP2',
    'SIGNAL in 15 - E-stop button',
  ];

  it('reads each line: direction, number, guarded, and the name with its blanks', () => {
    expect(parseSignal('out 0 guarded vacuum valve')).toEqual({ dir: 'out', n: 0, guarded: true, name: 'vacuum valve' });
    expect(parseSignal('in 14 - interlock LP1 LP2')).toEqual({ dir: 'in', n: 14, guarded: false, name: 'interlock LP1 LP2' });
    expect(parseSignal('in 15 - E-stop button  ')).toEqual({ dir: 'in', n: 15, guarded: false, name: 'E-stop button' });
  });

  it('refuses what is not one', () => {
    for (const bad of ['', 'out 0 guarded', 'out x - name', 'both 1 - name', 'out 32 - name', 'out 1 maybe name']) {
      expect(parseSignal(bad), bad).toBeNull();
    }
  });

  it('the ROBOT reply keeps them beside the axes, inputs first; an older controller gives none', () => {
    const r = robotFromReply({ name: 'paper-300mm', axes: '1' }, ['AXIS 1 name=j1 role=shoulder unit=deg ppu=1000', ...lines, 'SIGNAL junk']);
    expect(r.axes).toHaveLength(1);
    expect(r.signals?.map((s) => `${s.dir}${s.n}${s.guarded ? '!' : ''} ${s.name}`)).toEqual([
      'in0 vacuum sensor',
      'in14 interlock LP1 LP2',
      'in15 E-stop button',
      'out0! vacuum valve',
      'out1 mapping sensor',
    ]);
    expect(robotFromReply({}, ['AXIS 1 name=j1']).signals).toEqual([]);
  });
});
