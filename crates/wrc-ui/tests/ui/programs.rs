//! `GET /api/programs` and `GET /api/programs/<name>`: the editor opens the stored programs
//! and libraries (`wafer_cycle`, `cell_lib`) from the program folder, with their points.

use crate::{http, start};

#[test]
fn the_stored_programs_and_libraries_are_listed_and_read_with_their_points() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("wafer_cycle.wrl"),
        "INCLUDE \"cell_lib\"\nHOME\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("cell_lib.wrl"),
        "SUB greet(n)\n  PRINT n\nENDSUB\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("wafer_cycle.points.toml"),
        "[points]\nSAFE = { x = 260.0, y = 40.0, z = 10.0, yaw = 0.0 }\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("notes.txt"), "not a program").unwrap();
    std::fs::write(dir.path().join("bad name.wrl"), "HOME\n").unwrap();
    let ui = start(Some(dir.path().to_path_buf()), None);
    let addr = ui.local_addr();

    let list = http(addr, "GET", "/api/programs", &[], "");
    assert_eq!(list.status, 200, "{list:?}");
    assert_eq!(
        list.json()["programs"],
        serde_json::json!(["cell_lib", "wafer_cycle"])
    );

    let p = http(addr, "GET", "/api/programs/wafer_cycle", &[], "").json();
    assert_eq!(p["name"], "wafer_cycle");
    assert_eq!(p["source"], "INCLUDE \"cell_lib\"\nHOME\n");
    assert!(p["points"].as_str().unwrap().contains("SAFE"), "{p}");
    let lib = http(addr, "GET", "/api/programs/cell_lib", &[], "").json();
    assert_eq!(lib["points"], "", "a library without points");

    let missing = http(addr, "GET", "/api/programs/nothing_here", &[], "");
    assert_eq!(missing.status, 404);
    assert!(
        missing.json()["error"]
            .as_str()
            .unwrap()
            .contains("nothing_here is not stored"),
        "{missing:?}"
    );
    // A name that could reach outside the folder is refused before any file is read.
    assert_eq!(
        http(addr, "GET", "/api/programs/..%2Fsecret", &[], "").status,
        400
    );
    assert_eq!(http(addr, "POST", "/api/programs", &[], "").status, 405);
    ui.stop();
}

#[test]
fn without_a_program_folder_it_says_so() {
    let ui = start(None, None);
    let a = http(ui.local_addr(), "GET", "/api/programs", &[], "");
    assert_eq!(a.status, 404);
    assert!(
        a.json()["error"].as_str().unwrap().contains("--programs"),
        "{a:?}"
    );
    ui.stop();
}

#[test]
fn another_sites_page_may_not_read_them() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("demo.wrl"), "HOME\n").unwrap();
    let ui = start(Some(dir.path().to_path_buf()), None);
    let a = http(
        ui.local_addr(),
        "GET",
        "/api/programs/demo",
        &[("origin", "http://evil.example")],
        "",
    );
    assert_eq!(a.status, 403);
    ui.stop();
}
