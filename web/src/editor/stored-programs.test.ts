import { describe, expect, it } from 'vitest';
import { fetchProgramNames, fetchProgramText, mergeNames, type FetchLike } from './stored-programs';
import { libraryPlace } from './library-peek';

/** A fetch answering from a table of URLs. */
function fetcher(table: Record<string, { status: number; body: unknown }>): { f: FetchLike; asked: string[] } {
  const asked: string[] = [];
  const f: FetchLike = async (url) => {
    asked.push(url);
    const a = table[url] ?? { status: 404, body: { error: 'no' } };
    return { ok: a.status === 200, status: a.status, json: async () => a.body };
  };
  return { f, asked };
}

describe('the stored programs the editor opens', () => {
  it("lists wrc ui's folder (with the page's token) and reads a program's text", async () => {
    const { f, asked } = fetcher({
      'api/programs?token=t0k3n-abc': { status: 200, body: { programs: ['cell_lib', 'wafer_cycle', 3] } },
      'api/programs/wafer_cycle': { status: 200, body: { name: 'wafer_cycle', source: 'INCLUDE "cell_lib"\n', points: '' } },
    });
    expect(await fetchProgramNames(f, { search: '?token=t0k3n-abc' })).toEqual(['cell_lib', 'wafer_cycle']);
    expect(await fetchProgramText(f, { search: '' }, 'wafer_cycle')).toEqual({ ok: true, source: 'INCLUDE "cell_lib"\n' });
    expect(asked[0]).toBe('api/programs?token=t0k3n-abc');
  });

  it("says why a text cannot be read, and an unreachable wrc ui lists nothing", async () => {
    const { f } = fetcher({ 'api/programs/gone': { status: 404, body: { error: 'gone is not stored here' } } });
    expect(await fetchProgramText(f, { search: '' }, 'gone')).toEqual({ ok: false, why: 'gone is not stored here' });
    const broken: FetchLike = async () => {
      throw new Error('offline');
    };
    expect(await fetchProgramNames(broken, { search: '' })).toEqual([]);
    expect(await fetchProgramText(broken, { search: '' }, 'x')).toEqual({ ok: false, why: 'offline' });
  });

  it("merges the controller's list and the folder's, once each, sorted", () => {
    expect(mergeNames(['wafer_cycle', 'demo'], ['cell_lib', 'wafer_cycle'])).toEqual(['cell_lib', 'demo', 'wafer_cycle']);
  });
});

describe("a library's source while stepping inside it", () => {
  const v = (over: Partial<Parameters<typeof libraryPlace>[0]>) =>
    ({ program: 'wafer_cycle', state: 'paused', files: ['wafer_cycle', 'cell_lib'], position: null, prompt: null, ...over }) as Parameters<typeof libraryPlace>[0];

  it('is shown while the editor\u2019s program stands in one of its libraries', () => {
    expect(libraryPlace(v({ position: { fileIndex: 1, file: 'cell_lib', line: 30 } }), 'wafer_cycle')).toEqual({ file: 'cell_lib', line: 30 });
  });

  it('not in the program\u2019s own file, for another program, or when none runs', () => {
    expect(libraryPlace(v({ position: { fileIndex: 0, file: 'wafer_cycle', line: 3 } }), 'wafer_cycle')).toBeNull();
    expect(libraryPlace(v({ position: { fileIndex: 1, file: 'cell_lib', line: 30 } }), 'other')).toBeNull();
    expect(libraryPlace(v({ state: 'none', position: { fileIndex: 1, file: 'cell_lib', line: 30 } }), 'wafer_cycle')).toBeNull();
  });
});
