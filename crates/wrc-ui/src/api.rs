//! The editor's HTTP API: `POST /api/compile` (a program compiled without a controller, on a
//! blocking thread, at most [`crate::PARALLEL_COMPILES`] at once) and `GET /api/language`
//! (the language's built-ins, statements and keywords); `GET /api/programs` and `GET
//! /api/programs/<name>` (the stored programs and libraries, read from the program folder,
//! for the editor's Open). Same token and origin rules as
//! `/ws`; answers and refusals are JSON (`{"error": "…"}` for a refusal).

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Query, State};
use axum::http::{header, HeaderMap, Method, StatusCode};
use axum::response::{IntoResponse, Response};

use crate::compile::{self, MAX_REQUEST_BYTES};
use crate::{connection_after, refusal, App};

/// A JSON answer; a refusal also closes the connection.
fn json(status: StatusCode, body: String) -> Response {
    (
        status,
        [
            (header::CONTENT_TYPE, "application/json"),
            (header::CACHE_CONTROL, "no-store"),
            (header::CONNECTION, connection_after(status)),
        ],
        body,
    )
        .into_response()
}

/// `{"error": "<why>"}` with `status`.
fn error(status: StatusCode, why: &str) -> Response {
    json(status, serde_json::json!({ "error": why }).to_string())
}

/// Whether the body is declared JSON (`application/json`, any parameters). Requiring it
/// also keeps another site's page from sending a form-like POST without the browser's
/// CORS preflight, which `wrc ui` never answers.
fn is_json(headers: &HeaderMap) -> bool {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
        .is_some_and(|v| v.trim().eq_ignore_ascii_case("application/json"))
}

/// `POST /api/compile`: `{name, source, files, points}` → `{ok, diagnostics, symbols,
/// files, instructions}` (docs/gui.md).
pub(crate) async fn compile(
    State(app): State<App>,
    method: Method,
    headers: HeaderMap,
    Query(query): Query<Vec<(String, String)>>,
    body: Result<Bytes, BytesRejection>,
) -> Response {
    if method != Method::POST {
        return error(StatusCode::METHOD_NOT_ALLOWED, "only POST");
    }
    if let Some(why) = refusal(&app, &headers, &query) {
        return error(StatusCode::FORBIDDEN, why);
    }
    if !is_json(&headers) {
        return error(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "send the request as Content-Type: application/json",
        );
    }
    let body = match body {
        Ok(b) => b,
        Err(e) if e.status() == StatusCode::PAYLOAD_TOO_LARGE => {
            return error(
                StatusCode::PAYLOAD_TOO_LARGE,
                &format!(
                    "the request is larger than {} MiB; a program has at most {} lines of {} bytes",
                    MAX_REQUEST_BYTES >> 20,
                    compile::MAX_PROGRAM_LINES,
                    compile::MAX_LINE_BYTES
                ),
            );
        }
        Err(e) => return error(e.status(), &e.body_text()),
    };
    let request = match compile::parse_request(&body) {
        Ok(r) => r,
        Err(e) => return error(StatusCode::BAD_REQUEST, &e.to_string()),
    };
    // Wait for a turn, then compile off the async workers (a long program takes a while).
    let Ok(permit) = app.compiles.clone().acquire_owned().await else {
        return error(StatusCode::SERVICE_UNAVAILABLE, "wrc ui is stopping");
    };
    let (robot, programs) = (app.robot.clone(), app.programs.clone());
    let done = tokio::task::spawn_blocking(move || {
        let reply = compile::compile(&request, &robot, programs.as_deref().map(|p| p.as_path()));
        drop(permit);
        serde_json::to_string(&reply)
    })
    .await;
    match done {
        Ok(Ok(body)) => json(StatusCode::OK, body),
        Ok(Err(e)) => error(
            StatusCode::INTERNAL_SERVER_ERROR,
            &format!("the compiler's answer could not be written: {e}"),
        ),
        Err(e) => {
            app.hub
                .note(&format!("wrc ui: the compiler failed on a request: {e}"));
            error(
                StatusCode::INTERNAL_SERVER_ERROR,
                "the compiler failed on this program (a bug: wrc ui's log has it); the controller still compiles it on upload",
            )
        }
    }
}

/// `GET /api/language`: `{functions: [{name, syntax, summary}], statements: [{keyword,
/// syntax, summary}], keywords: […]}`.
pub(crate) async fn language(
    State(app): State<App>,
    method: Method,
    headers: HeaderMap,
    Query(query): Query<Vec<(String, String)>>,
) -> Response {
    if method != Method::GET && method != Method::HEAD {
        return error(StatusCode::METHOD_NOT_ALLOWED, "only GET");
    }
    if let Some(why) = refusal(&app, &headers, &query) {
        return error(StatusCode::FORBIDDEN, why);
    }
    json(StatusCode::OK, compile::language_json().to_string())
}

/// The text of a stored program and its points, as `GET /api/programs/<name>` answers it.
#[derive(Debug, serde::Serialize)]
struct StoredProgram {
    name: String,
    source: String,
    /// Its points file (`<name>.points.toml`), '' when it has none.
    points: String,
}

/// The stored programs in `dir` (each `<name>.wrl` whose name is a program's), sorted.
fn list_programs(dir: &std::path::Path) -> std::io::Result<Vec<String>> {
    let mut names: Vec<String> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let stem = name.strip_suffix(".wrl")?;
            compile::name_ok(stem).then(|| stem.to_string())
        })
        .collect();
    names.sort();
    Ok(names)
}

/// Why the program folder cannot be read, for the editor: the folder is not known here.
const NO_FOLDER: &str = "wrc ui has no program folder (wrc ui --programs DIR): the editor can open only what this browser has";

/// `GET /api/programs`: `{programs: ["cell_lib", "wafer_cycle", …]}`, the `.wrl` files of
/// `wrc ui --programs DIR` (the controller's stored programs and libraries under `wrc up`).
pub(crate) async fn programs(
    State(app): State<App>,
    method: Method,
    headers: HeaderMap,
    Query(query): Query<Vec<(String, String)>>,
) -> Response {
    if method != Method::GET && method != Method::HEAD {
        return error(StatusCode::METHOD_NOT_ALLOWED, "only GET");
    }
    if let Some(why) = refusal(&app, &headers, &query) {
        return error(StatusCode::FORBIDDEN, why);
    }
    let Some(dir) = app.programs.clone() else {
        return error(StatusCode::NOT_FOUND, NO_FOLDER);
    };
    match tokio::task::spawn_blocking(move || list_programs(&dir)).await {
        Ok(Ok(names)) => json(
            StatusCode::OK,
            serde_json::json!({ "programs": names }).to_string(),
        ),
        Ok(Err(e)) => error(
            StatusCode::NOT_FOUND,
            &format!("the program folder cannot be read: {e}"),
        ),
        Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, &e.to_string()),
    }
}

/// `GET /api/programs/<name>`: `{name, source, points}` of a stored program or library, read
/// from `wrc ui --programs DIR` (404 with a sentence when there is none).
pub(crate) async fn program(
    State(app): State<App>,
    method: Method,
    headers: HeaderMap,
    Query(query): Query<Vec<(String, String)>>,
    axum::extract::Path(name): axum::extract::Path<String>,
) -> Response {
    if method != Method::GET && method != Method::HEAD {
        return error(StatusCode::METHOD_NOT_ALLOWED, "only GET");
    }
    if let Some(why) = refusal(&app, &headers, &query) {
        return error(StatusCode::FORBIDDEN, why);
    }
    if !compile::name_ok(&name) {
        return error(
            StatusCode::BAD_REQUEST,
            "a program's name is 1-32 letters, digits, _ or -",
        );
    }
    let Some(dir) = app.programs.clone() else {
        return error(StatusCode::NOT_FOUND, NO_FOLDER);
    };
    let read = tokio::task::spawn_blocking(move || {
        let source = std::fs::read_to_string(dir.join(format!("{name}.wrl")))
            .map_err(|e| format!("{name} is not stored here ({e})"))?;
        let points =
            std::fs::read_to_string(dir.join(format!("{name}.points.toml"))).unwrap_or_default();
        Ok::<_, String>(StoredProgram {
            name,
            source,
            points,
        })
    })
    .await;
    match read {
        Ok(Ok(p)) => json(
            StatusCode::OK,
            serde_json::to_string(&p).unwrap_or_else(|_| "{}".into()),
        ),
        Ok(Err(why)) => error(StatusCode::NOT_FOUND, &why),
        Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, &e.to_string()),
    }
}
