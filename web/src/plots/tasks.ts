// Parser of the `EVT TASK` lines of the `TASKS` reply (docs/protocol.md, "Robot and task
// queries"):
//   TASK error_check prio=10 period_ms=100 cycles=52 overruns=0 missed=0 per_avg_us=100000.2
//        per_min_us=99981.3 per_max_us=100034.9 exec_avg_us=3.1 exec_max_us=12.4
//        lat_avg_us=41.2 lat_p99_us=88 lat_max_us=91.5 lat_hist=32:3,64:40,128:9

import type { TaskTiming } from '../protocol/bus';

const NUMERIC_KEYS: Record<string, keyof TaskTiming> = {
  prio: 'priority',
  period_ms: 'periodMs',
  cycles: 'cycles',
  overruns: 'overruns',
  missed: 'missed',
  per_avg_us: 'periodAvgUs',
  per_min_us: 'periodMinUs',
  per_max_us: 'periodMaxUs',
  exec_avg_us: 'execAvgUs',
  exec_max_us: 'execMaxUs',
  lat_avg_us: 'latAvgUs',
  lat_p99_us: 'latP99Us',
  lat_max_us: 'latMaxUs',
};

/** Parse `u:n,u:n,…` (empty: no bins). Bins are sorted by upper bound; null if malformed. */
export function parseLatHist(text: string): [number, number][] | null {
  if (text === '') return [];
  const bins: [number, number][] = [];
  for (const part of text.split(',')) {
    const m = /^(\d+(?:\.\d+)?):(\d+)$/.exec(part);
    if (!m) return null;
    bins.push([Number(m[1]), Number(m[2])]);
  }
  bins.sort((a, b) => a[0] - b[0]);
  return bins;
}

/**
 * Parse one task line, with or without its `EVT ` prefix. Returns null when the line is not
 * a `TASK` line or has no task name. Keys that are absent read as 0 (the controller's value
 * before a task has run); a value that is not a number reads as NaN; unknown keys are
 * ignored (a newer controller may add some).
 */
export function parseTaskLine(line: string): TaskTiming | null {
  const words = line.trim().split(/\s+/);
  let k = 0;
  if (words[k] === 'EVT') k++;
  if (words[k] !== 'TASK') return null;
  k++;
  const name = words[k];
  if (name === undefined || name === '' || name.includes('=')) return null;
  k++;
  const t: TaskTiming = {
    name,
    priority: 0,
    periodMs: 0,
    cycles: 0,
    overruns: 0,
    missed: 0,
    periodAvgUs: 0,
    periodMinUs: 0,
    periodMaxUs: 0,
    execAvgUs: 0,
    execMaxUs: 0,
    latAvgUs: 0,
    latP99Us: 0,
    latMaxUs: 0,
    latHist: [],
  };
  const rec = t as unknown as Record<string, number>;
  for (; k < words.length; k++) {
    const w = words[k] as string;
    const eq = w.indexOf('=');
    if (eq <= 0) continue;
    const key = w.slice(0, eq);
    const value = w.slice(eq + 1);
    if (key === 'lat_hist') {
      t.latHist = parseLatHist(value) ?? [];
      continue;
    }
    const field = NUMERIC_KEYS[key];
    if (field !== undefined) rec[field] = value === '' ? NaN : Number(value);
  }
  return t;
}

/** Every task of a `TASKS` reply's events, in their order; other lines are skipped. */
export function parseTasks(events: readonly string[]): TaskTiming[] {
  const out: TaskTiming[] = [];
  for (const line of events) {
    const t = parseTaskLine(line);
    if (t) out.push(t);
  }
  return out;
}
