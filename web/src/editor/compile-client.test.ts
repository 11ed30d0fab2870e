import { afterEach, beforeEach, describe, expect, it, vi } from 'vitest';
import { LiveCompiler, apiUrl, libraryFiles, referencedPrograms, type CompileRequest, type CompileResult } from './compile-client';

const result = (n: number): CompileResult => ({ ok: true, diagnostics: [], symbols: [], files: ['demo'], instructions: n });
const request = (source: string): CompileRequest => ({ name: 'demo', source, files: {}, points: '' });

/** A fetch whose answers the test releases one by one. */
function fakeFetch() {
  const calls: { body: CompileRequest; signal: AbortSignal; answer: (r: Response) => void; fail: (e: Error) => void }[] = [];
  const fetch = (_url: string, init: RequestInit) =>
    new Promise<Response>((answer, fail) => {
      calls.push({ body: JSON.parse(String(init.body)) as CompileRequest, signal: init.signal as AbortSignal, answer, fail });
    });
  return { fetch, calls };
}

describe('LiveCompiler', () => {
  beforeEach(() => vi.useFakeTimers());
  afterEach(() => vi.useRealTimers());

  it('compiles once, 300 ms after the last change', async () => {
    const f = fakeFetch();
    const got: number[] = [];
    const c = new LiveCompiler({ fetch: f.fetch, url: 'api/compile', onResult: (r) => got.push(r.instructions), onError: () => undefined });
    c.schedule(() => request('A'));
    vi.advanceTimersByTime(200);
    c.schedule(() => request('AB'));
    vi.advanceTimersByTime(299);
    expect(f.calls).toHaveLength(0);
    vi.advanceTimersByTime(1);
    expect(f.calls.map((x) => x.body.source)).toEqual(['AB']);
    f.calls[0].answer(new Response(JSON.stringify(result(7))));
    await vi.runAllTimersAsync();
    expect(got).toEqual([7]);
  });

  it('delivers only the latest answer and aborts the one it replaces', async () => {
    const f = fakeFetch();
    const got: string[] = [];
    const c = new LiveCompiler({ fetch: f.fetch, url: 'api/compile', onResult: (_r, q) => got.push(q.source), onError: () => undefined });
    const first = c.now(request('old'));
    const second = c.now(request('new'));
    expect(f.calls[0].signal.aborted).toBe(true);
    f.calls[1].answer(new Response(JSON.stringify(result(2))));
    // The old one answers late anyway: not delivered.
    f.calls[0].answer(new Response(JSON.stringify(result(1))));
    await Promise.all([first, second]);
    expect(got).toEqual(['new']);
  });

  it("says why when wrc ui refuses or cannot be reached", async () => {
    const f = fakeFetch();
    const errors: string[] = [];
    const c = new LiveCompiler({ fetch: f.fetch, url: 'api/compile', onResult: () => undefined, onError: (m) => errors.push(m) });
    const a = c.now(request('x'));
    f.calls[0].answer(new Response(JSON.stringify({ error: 'a page of another origin …' }), { status: 403 }));
    await a;
    const b = c.now(request('y'));
    f.calls[1].fail(new TypeError('Failed to fetch'));
    await b;
    expect(errors).toEqual(['a page of another origin …', 'Failed to fetch']);
  });
});

describe('what goes with a compile', () => {
  it("adds the page's token", () => {
    expect(apiUrl('compile', { search: '' })).toBe('api/compile');
    expect(apiUrl('compile', { search: '?token=a b' })).toBe('api/compile?token=a%20b');
  });

  it('finds the programs a text names, not in comments', () => {
    const src = 'INCLUDE "cell_lib"\n  include "util"\nCALL PROGRAM "other" \' CALL PROGRAM "commented"\nPRINT "INCLUDE \\"no\\""\nIF X THEN CALL PROGRAM "inner"\n';
    expect(referencedPrograms(src)).toEqual(['cell_lib', 'util', 'other', 'inner']);
  });

  it("sends this browser's texts of the libraries, and theirs", () => {
    const known = { cell_lib: 'INCLUDE "util"\nSUB a()\nENDSUB\n', util: 'SUB b()\nENDSUB\n', unrelated: 'X = 1\n', demo: 'self' };
    expect(libraryFiles('INCLUDE "cell_lib"\nINCLUDE "missing"\nCALL PROGRAM "demo"\n', known, 'demo')).toEqual({
      cell_lib: known.cell_lib,
      util: known.util,
    });
  });
});
