// The editor's side of `wrc ui`'s compiler (docs/gui.md, "The editor's compiler"): the request
// and reply types, the URL with the page's `?token=`, and `LiveCompiler`, which compiles the
// text ~300 ms after the last change, one request at a time in effect: a newer request aborts
// the one in flight and only the latest answer is delivered. It needs no controller.

import type { LanguageInfo, SymbolInfo } from './completion';

/** `POST /api/compile`'s body. */
export interface CompileRequest {
  name: string;
  source: string;
  /** Libraries and called programs by name (the rest are read from the program folder). */
  files: Record<string, string>;
  /** The program's points file (TOML), '' for the program folder's. */
  points: string;
}

/** One diagnostic of the reply. */
export interface CompileDiagnostic {
  /** null: the program itself; else the library or called program it is in. */
  file: string | null;
  line: number;
  col: number;
  len: number;
  severity: 'error' | 'warning';
  message: string;
}

/** `POST /api/compile`'s answer. */
export interface CompileResult {
  ok: boolean;
  diagnostics: CompileDiagnostic[];
  symbols: SymbolInfo[];
  files: string[];
  instructions: number;
}

/** `/api/<path>` of the page's host, with the page's `?token=`. */
export function apiUrl(path: string, loc: { search: string }): string {
  const token = new URLSearchParams(loc.search).get('token');
  return `api/${path}${token ? `?token=${encodeURIComponent(token)}` : ''}`;
}

/**
 * The stored programs `source` names (`INCLUDE "lib"`, `CALL PROGRAM "name"`), in order, each
 * once; comments and other strings are skipped.
 */
export function referencedPrograms(source: string): string[] {
  const out: string[] = [];
  const add = (name: string) => {
    if (!out.includes(name)) out.push(name);
  };
  for (const line of source.split('\n')) {
    // Without its comment and its other strings' insides (a name is never in a comment).
    const code = line.replace(/^((?:[^"']|"[^"]*")*)'.*$/, '$1');
    const include = /^\s*INCLUDE[ \t]+"([A-Za-z0-9_-]{1,32})"/i.exec(code);
    if (include) add(include[1]);
    for (const m of code.matchAll(/\bCALL[ \t]+PROGRAM[ \t]+"([A-Za-z0-9_-]{1,32})"/gi)) add(m[1]);
  }
  return out;
}

/**
 * The texts this browser has of the programs `source` names, and of those they name in turn
 * (`known`: name → text), for `files`.
 */
export function libraryFiles(source: string, known: Readonly<Record<string, string>>, self: string): Record<string, string> {
  const files: Record<string, string> = {};
  const todo = referencedPrograms(source);
  while (todo.length > 0) {
    const name = todo.shift()!;
    if (name === self || name in files || !(name in known)) continue;
    files[name] = known[name];
    todo.push(...referencedPrograms(known[name]));
  }
  return files;
}

/** Read a `fetch` answer as JSON; an answer that is not, or an `{error}`, throws its text. */
async function readJson<T>(r: Response): Promise<T> {
  const text = await r.text();
  let body: unknown;
  try {
    body = JSON.parse(text);
  } catch {
    throw new Error(`wrc ui answered ${r.status}: ${text.slice(0, 200)}`);
  }
  if (!r.ok) {
    const e = (body as { error?: unknown }).error;
    throw new Error(typeof e === 'string' ? e : `wrc ui answered ${r.status}`);
  }
  return body as T;
}

export interface LiveCompilerOptions {
  /** `fetch` (tests give a fake). */
  fetch: (url: string, init: RequestInit) => Promise<Response>;
  /** `/api/compile`'s URL. */
  url: string;
  /** Quiet time after the last change before compiling [ms]; default 300. */
  delayMs?: number;
  setTimeout?: (fn: () => void, ms: number) => unknown;
  clearTimeout?: (h: unknown) => void;
  /** The answer to the latest request. */
  onResult: (result: CompileResult, request: CompileRequest) => void;
  /** The latest request failed (wrc ui unreachable, a refusal). */
  onError: (message: string, request: CompileRequest) => void;
  /** A compile started (after the quiet time). */
  onStart?: (request: CompileRequest) => void;
}

/** Compiles the latest text after a quiet time; older answers are never delivered. */
export class LiveCompiler {
  private timer: unknown = null;
  private seq = 0;
  private inFlight: AbortController | null = null;
  private readonly delayMs: number;
  private readonly setT: (fn: () => void, ms: number) => unknown;
  private readonly clearT: (h: unknown) => void;

  constructor(private readonly opts: LiveCompilerOptions) {
    this.delayMs = opts.delayMs ?? 300;
    this.setT = opts.setTimeout ?? ((fn, ms) => setTimeout(fn, ms));
    this.clearT = opts.clearTimeout ?? ((h) => clearTimeout(h as ReturnType<typeof setTimeout>));
  }

  /** Compile `make()`'s request after the quiet time (a later call restarts it). */
  schedule(make: () => CompileRequest): void {
    if (this.timer !== null) this.clearT(this.timer);
    this.timer = this.setT(() => {
      this.timer = null;
      void this.now(make());
    }, this.delayMs);
  }

  /** Compile `request` at once; resolves when its answer was handled (or superseded). */
  async now(request: CompileRequest): Promise<void> {
    if (this.timer !== null) {
      this.clearT(this.timer);
      this.timer = null;
    }
    const seq = ++this.seq;
    this.inFlight?.abort();
    const abort = new AbortController();
    this.inFlight = abort;
    this.opts.onStart?.(request);
    let result: CompileResult;
    try {
      const r = await this.opts.fetch(this.opts.url, {
        method: 'POST',
        headers: { 'Content-Type': 'application/json' },
        body: JSON.stringify(request),
        signal: abort.signal,
      });
      result = await readJson<CompileResult>(r);
    } catch (e) {
      if (seq !== this.seq) return; // superseded (and aborted): a newer answer comes
      this.inFlight = null;
      this.opts.onError(e instanceof Error ? e.message : String(e), request);
      return;
    }
    if (seq !== this.seq) return;
    this.inFlight = null;
    this.opts.onResult(result, request);
  }

  /** Stop: no pending compile, none delivered. */
  cancel(): void {
    if (this.timer !== null) this.clearT(this.timer);
    this.timer = null;
    this.seq++;
    this.inFlight?.abort();
    this.inFlight = null;
  }
}

/** `GET /api/language`. */
export async function fetchLanguage(
  fetchFn: (url: string, init: RequestInit) => Promise<Response>,
  url: string,
): Promise<LanguageInfo> {
  return readJson(await fetchFn(url, { method: 'GET' }));
}
