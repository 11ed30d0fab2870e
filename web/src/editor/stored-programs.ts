// The stored programs and libraries the editor opens: their names (the controller's
// `PROGRAMS`, and the files of `wrc ui --programs DIR` through `GET /api/programs`) and their
// text (`GET /api/programs/<name>`; the controller keeps a program's text but does not give it
// back). No DOM.

import { apiUrl } from './compile-client';

/** What a fetch needs (the browser's, or a fake in tests). */
export type FetchLike = (url: string) => Promise<{ ok: boolean; status: number; json(): Promise<unknown> }>;

/** The stored programs' names that `wrc ui` can read (empty when it has no program folder). */
export async function fetchProgramNames(fetcher: FetchLike, loc: { search: string }): Promise<string[]> {
  try {
    const r = await fetcher(apiUrl('programs', loc));
    if (!r.ok) return [];
    const body = (await r.json()) as { programs?: unknown };
    return Array.isArray(body.programs) ? body.programs.filter((p): p is string => typeof p === 'string') : [];
  } catch {
    return [];
  }
}

/** A stored program's text, or why it could not be read. */
export type StoredText = { ok: true; source: string } | { ok: false; why: string };

/** The text of stored program or library `name`, read by `wrc ui` from the program folder. */
export async function fetchProgramText(fetcher: FetchLike, loc: { search: string }, name: string): Promise<StoredText> {
  const url = apiUrl(`programs/${encodeURIComponent(name)}`, loc);
  try {
    const r = await fetcher(url);
    const body = (await r.json().catch(() => ({}))) as { source?: unknown; error?: unknown };
    if (r.ok && typeof body.source === 'string') return { ok: true, source: body.source };
    return { ok: false, why: typeof body.error === 'string' ? body.error : `wrc ui answered ${r.status}` };
  } catch (e) {
    return { ok: false, why: e instanceof Error ? e.message : String(e) };
  }
}

/** Every name once, sorted: the controller's list and wrc ui's folder together. */
export function mergeNames(...lists: readonly (readonly string[])[]): string[] {
  return [...new Set(lists.flat())].sort((a, b) => a.localeCompare(b));
}
