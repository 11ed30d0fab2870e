import { describe, expect, it } from 'vitest';
import { parseLatHist, parseTaskLine, parseTasks } from './tasks';

const LINE =
  'TASK error_check prio=10 period_ms=100 cycles=52 overruns=0 missed=0 per_avg_us=100000.2 ' +
  'per_min_us=99981.3 per_max_us=100034.9 exec_avg_us=3.1 exec_max_us=12.4 lat_avg_us=41.2 ' +
  'lat_p99_us=88 lat_max_us=91.5 lat_hist=32:3,64:40,128:9';

describe('parseTaskLine', () => {
  it('parses the documented example (docs/protocol.md)', () => {
    expect(parseTaskLine(LINE)).toEqual({
      name: 'error_check',
      priority: 10,
      periodMs: 100,
      cycles: 52,
      overruns: 0,
      missed: 0,
      periodAvgUs: 100000.2,
      periodMinUs: 99981.3,
      periodMaxUs: 100034.9,
      execAvgUs: 3.1,
      execMaxUs: 12.4,
      latAvgUs: 41.2,
      latP99Us: 88,
      latMaxUs: 91.5,
      latHist: [
        [32, 3],
        [64, 40],
        [128, 9],
      ],
    });
  });

  it('accepts the EVT prefix, extra blanks and unknown keys', () => {
    const t = parseTaskLine(`EVT  ${LINE}  cpu=3 future_key=x`);
    expect(t?.name).toBe('error_check');
    expect(t?.latP99Us).toBe(88);
  });

  it('reads a task that has not run yet (zeros, empty or absent histogram)', () => {
    const t = parseTaskLine('TASK rs232c prio=45 period_ms=100 cycles=0 lat_hist=');
    expect(t?.cycles).toBe(0);
    expect(t?.latMaxUs).toBe(0);
    expect(t?.latHist).toEqual([]);
    expect(parseTaskLine('TASK ethernet prio=45')?.latHist).toEqual([]);
  });

  it('marks a value that is not a number as NaN and ignores a malformed histogram', () => {
    const t = parseTaskLine('TASK x prio=1 lat_avg_us=abc lat_hist=1:2,zz');
    expect(t?.latAvgUs).toBeNaN();
    expect(t?.latHist).toEqual([]);
  });

  it('rejects lines that are not task lines', () => {
    expect(parseTaskLine('AXIS 1 name=j1 role=shoulder')).toBeNull();
    expect(parseTaskLine('TASK')).toBeNull();
    expect(parseTaskLine('TASK prio=10')).toBeNull();
    expect(parseTaskLine('')).toBeNull();
  });
});

describe('parseLatHist', () => {
  it('sorts bins and reads the sub-microsecond bin', () => {
    expect(parseLatHist('64:1,1:7,2:3')).toEqual([
      [1, 7],
      [2, 3],
      [64, 1],
    ]);
    expect(parseLatHist('')).toEqual([]);
    expect(parseLatHist('1:')).toBeNull();
    expect(parseLatHist('a:1')).toBeNull();
  });
});

describe('parseTasks', () => {
  it('keeps task lines in order and skips the others', () => {
    const tasks = parseTasks([
      LINE,
      'DIAG something',
      'TASK pulse_generator prio=20 period_ms=10 cycles=500',
      'TASK simulator_manager prio=25 period_ms=10',
    ]);
    expect(tasks.map((t) => t.name)).toEqual(['error_check', 'pulse_generator', 'simulator_manager']);
    expect(tasks[1]?.periodMs).toBe(10);
  });
});
