//! `POST /api/compile` and `GET /api/language`: the editor's compiler, which answers with no
//! controller at all, and refuses what a browser page of another site could send.

use serde_json::json;

use crate::{http, post_compile, post_unread, start};

#[test]
fn an_error_comes_back_at_its_line_and_column() {
    let ui = start(None, None);
    let answer = post_compile(
        ui.local_addr(),
        &json!({
            "name": "demo",
            "source": "SPEED 50\nX = 1\nPRINT \"total\", TOTAL, X\n",
        }),
    );
    assert_eq!(answer.status, 200, "{answer:?}");
    assert_eq!(answer.content_type, "application/json");
    let v = answer.json();
    assert_eq!(v["ok"], false);
    assert_eq!(v["instructions"], 0);
    let d = &v["diagnostics"][0];
    assert_eq!(
        (d["line"].as_u64(), d["col"].as_u64()),
        (Some(3), Some(16)),
        "{d}"
    );
    assert_eq!(d["len"], 5);
    assert_eq!(d["severity"], "error");
    assert_eq!(d["file"], serde_json::Value::Null);
    assert!(d["message"].as_str().unwrap().contains("TOTAL"), "{d}");
    ui.stop();
}

#[test]
fn a_good_program_compiles_with_its_symbols() {
    let ui = start(None, None);
    let v = post_compile(
        ui.local_addr(),
        &json!({
            "name": "demo",
            "source": "DIM slots[25]\nCOUNT = 0\nCALL fill(3)\nSUB fill(n)\n  LOCAL k = n * 2\n  COUNT = COUNT + k\nENDSUB\n",
        }),
    )
    .json();
    assert_eq!(v["ok"], true, "{v}");
    assert!(v["instructions"].as_u64().unwrap() > 0);
    assert_eq!(v["files"], json!(["demo"]));
    let find = |name: &str| {
        v["symbols"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == name)
            .unwrap_or_else(|| panic!("no symbol {name}: {v}"))
            .clone()
    };
    assert_eq!(find("slots")["kind"], "array");
    assert_eq!(find("fill")["kind"], "sub");
    assert_eq!(find("fill")["line"], 4);
    assert_eq!(find("n")["kind"], "parameter");
    assert_eq!(find("n")["scope"], "fill");
    assert_eq!(find("k")["kind"], "local");
    ui.stop();
}

#[test]
fn an_include_is_read_from_the_request_files_first_then_the_program_folder() {
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(
        folder.path().join("stored_lib.wrl"),
        "SUB stored_greet()\n  PRINT \"stored\"\nENDSUB\n",
    )
    .unwrap();
    std::fs::write(
        folder.path().join("cell_lib.wrl"),
        "SUB not_this_one()\nENDSUB\n",
    )
    .unwrap();
    let ui = start(Some(folder.path().to_path_buf()), None);
    let v = post_compile(
        ui.local_addr(),
        &json!({
            "name": "demo",
            "source": "INCLUDE \"cell_lib\"\nINCLUDE \"stored_lib\"\nCALL greet(2)\nCALL stored_greet()\n",
            "files": { "cell_lib": "SUB greet(n)\n  PRINT \"hi\", n\nENDSUB\n" },
        }),
    )
    .json();
    assert_eq!(v["ok"], true, "{v}");
    assert_eq!(v["files"], json!(["demo", "cell_lib", "stored_lib"]));
    let greet = v["symbols"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "greet")
        .cloned()
        .unwrap_or_else(|| panic!("{v}"));
    assert_eq!(
        (greet["file"].as_u64(), greet["line"].as_u64()),
        (Some(1), Some(1))
    );

    // An error in a library names it.
    let v = post_compile(
        ui.local_addr(),
        &json!({
            "name": "demo",
            "source": "INCLUDE \"cell_lib\"\nCALL greet(2)\n",
            "files": { "cell_lib": "SUB greet(n)\n  PRINT \"hi\", m\nENDSUB\n" },
        }),
    )
    .json();
    assert_eq!(v["ok"], false);
    let d = &v["diagnostics"][0];
    assert_eq!(
        (d["file"].as_str(), d["line"].as_u64()),
        (Some("cell_lib"), Some(2)),
        "{v}"
    );

    // Neither sent nor stored.
    let v = post_compile(
        ui.local_addr(),
        &json!({ "name": "demo", "source": "INCLUDE \"missing_lib\"\n" }),
    )
    .json();
    assert_eq!(v["ok"], false);
    assert!(
        v["diagnostics"][0]["message"]
            .as_str()
            .unwrap()
            .contains("missing_lib"),
        "{v}"
    );
    ui.stop();
}

#[test]
fn points_come_from_the_request_or_else_the_program_folder() {
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(
        folder.path().join("demo.points.toml"),
        "[points]\nSTORED = { x = 250.0, y = 0.0, z = 10.0, yaw = 0.0 }\n",
    )
    .unwrap();
    let ui = start(Some(folder.path().to_path_buf()), None);
    let source = "MOVEP SENT\n";
    let sent = "[points]\nSENT = { x = 260.0, y = 40.0, z = 10.0, yaw = 0.0 }\n";
    let v = post_compile(
        ui.local_addr(),
        &json!({ "name": "demo", "source": source, "points": sent }),
    )
    .json();
    assert_eq!(v["ok"], true, "{v}");
    assert!(v["symbols"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s["name"] == "SENT" && s["kind"] == "point"));
    // Without points in the request: the folder's file, which has no SENT.
    let v = post_compile(
        ui.local_addr(),
        &json!({ "name": "demo", "source": source, "points": "" }),
    )
    .json();
    assert_eq!(v["ok"], false, "{v}");
    let v = post_compile(
        ui.local_addr(),
        &json!({ "name": "demo", "source": "MOVEP STORED\n" }),
    )
    .json();
    assert_eq!(v["ok"], true, "{v}");
    // A points file the compiler cannot read is an error of the program.
    let v = post_compile(
        ui.local_addr(),
        &json!({ "name": "demo", "source": "X = 1\n", "points": "[points]\nP = 3\n" }),
    )
    .json();
    assert_eq!(v["ok"], false, "{v}");
    assert!(v["diagnostics"][0]["message"]
        .as_str()
        .unwrap()
        .contains("points file"));
    ui.stop();
}

#[test]
fn a_bad_request_is_a_400_that_says_what_is_wrong() {
    let ui = start(None, None);
    let addr = ui.local_addr();
    let json_header = [("content-type", "application/json")];
    let a = http(
        addr,
        "POST",
        "/api/compile",
        &json_header,
        "{\"name\": \"demo\",",
    );
    assert_eq!(a.status, 400, "{a:?}");
    assert!(
        a.json()["error"].as_str().unwrap().contains("not the JSON"),
        "{a:?}"
    );
    let a = http(
        addr,
        "POST",
        "/api/compile",
        &json_header,
        "{\"name\": \"demo\"}",
    );
    assert_eq!(a.status, 400);
    assert!(a.body.contains("missing field `source`"), "{a:?}");
    let a = post_compile(addr, &json!({ "name": "no/such", "source": "" }));
    assert_eq!(a.status, 400);
    assert!(a.body.contains("cannot name a program"), "{a:?}");
    // Not declared JSON, not POST, too large.
    let a = http(
        addr,
        "POST",
        "/api/compile",
        &[("content-type", "text/plain")],
        "{}",
    );
    assert_eq!(a.status, 415, "{a:?}");
    let a = http(addr, "GET", "/api/compile", &[], "");
    assert_eq!(a.status, 405, "{a:?}");
    let huge = json!({ "name": "demo", "source": "X = 1\n".repeat(2 << 20) });
    let a = post_unread(addr, "/api/compile", huge.to_string());
    assert_eq!(a.status, 413, "{a:?}");
    assert!(a.json()["error"].as_str().unwrap().contains("larger than"));
    // Still serving.
    let a = post_compile(addr, &json!({ "name": "demo", "source": "X = 1\n" }));
    assert_eq!(a.json()["ok"], true);
    ui.stop();
}

#[test]
fn a_page_of_another_origin_is_refused_and_a_token_is_required_when_set() {
    let ui = start(None, None);
    let addr = ui.local_addr();
    let body = json!({ "name": "demo", "source": "X = 1\n" }).to_string();
    let foreign = [
        ("content-type", "application/json"),
        ("origin", "http://evil.example"),
    ];
    let a = http(addr, "POST", "/api/compile", &foreign, body.clone());
    assert_eq!(a.status, 403, "{a:?}");
    assert!(a.body.contains("another origin"), "{a:?}");
    let a = http(addr, "GET", "/api/language", &foreign, "");
    assert_eq!(a.status, 403, "{a:?}");
    let own = format!("http://{addr}");
    let same = [
        ("content-type", "application/json"),
        ("origin", own.as_str()),
    ];
    let a = http(addr, "POST", "/api/compile", &same, body.clone());
    assert_eq!(a.status, 200, "{a:?}");
    ui.stop();

    let ui = start(None, Some("s3cret-token"));
    let addr = ui.local_addr();
    let json_header = [("content-type", "application/json")];
    let a = http(addr, "POST", "/api/compile", &json_header, body.clone());
    assert_eq!(a.status, 403, "{a:?}");
    let a = http(
        addr,
        "POST",
        "/api/compile?token=wrong-token",
        &json_header,
        body.clone(),
    );
    assert_eq!(a.status, 403, "{a:?}");
    let a = http(
        addr,
        "POST",
        "/api/compile?token=s3cret-token",
        &json_header,
        body,
    );
    assert_eq!(a.status, 200, "{a:?}");
    ui.stop();
}

#[test]
fn the_language_is_served_for_completion() {
    let ui = start(None, None);
    let a = http(ui.local_addr(), "GET", "/api/language", &[], "");
    assert_eq!(a.status, 200, "{a:?}");
    let v = a.json();
    assert!(v["functions"]
        .as_array()
        .unwrap()
        .iter()
        .any(|f| f["name"] == "WAFER$" && f["syntax"].as_str().unwrap().contains('(')));
    assert!(v["statements"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s["keyword"] == "MOVEL"));
    assert!(v["keywords"].as_array().unwrap().contains(&json!("ENDTRY")));
    ui.stop();
}
