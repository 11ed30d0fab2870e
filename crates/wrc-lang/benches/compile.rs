//! Compiler speed: a 10,000-line program (moves, pose arithmetic, loops, IFs, SUBs, PRINT)
//! compiled for the paper's robot, and one of the same length written with what real
//! sequences use (TRY/CATCH/RETRY, arrays, FUNCTIONs with parameters and locals, SELECT
//! CASE, DO loops, strings, cell questions, blended moves with options). Target: ≤ 50 ms.
//! Also the VM's cost per instruction.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use wrc_lang::{compile, Resume, Step, Vm, VmIo, VmLimits};
use wrc_robot::{Pose, Robot};

/// A program of `lines` lines built from a repeating block of realistic statements.
fn program(lines: usize) -> String {
    let mut src = String::from(
        "' generated benchmark program\nSPEED 50\nHOME\nAPPROACH = POSE(0, 0, 20, 0)\nN = 0\n",
    );
    let mut k = 0;
    while src.lines().count() < lines.saturating_sub(12) {
        let x = 220 + (k % 80);
        let y = -100 + (k % 200);
        src.push_str(&format!(
            "P{k} = POSE({x}, {y}, 10, {yaw})\n\
             MOVEP P{k} + APPROACH, R\n\
             MOVEL P{k}\n\
             IF N > {k} AND P{k}.X < 400 THEN\n  N = N - 1\nELSEIF N = {k} THEN\n  N = N + 2 * SIN(30)\nELSE\n  N = MAX(N, {k})\nENDIF\n\
             FOR i{k} = 1 TO 3\n  MOVEJ JOINTS(10 * i{k}, 60, -90, {z})\nNEXT i{k}\n\
             CALL S{k}\n\
             PRINT \"step\", {k}, P{k}\n",
            yaw = k % 90,
            z = k % 100,
        ));
        src.push_str(&format!(
            "SUB S{k}\n  OUT 0, 1\n  WAIT IN(0) = 1 TIMEOUT 2\n  DELAY 0.1\nENDSUB\n"
        ));
        k += 1;
    }
    src.push_str("END\n");
    src
}

/// A program of `lines` lines in the style of a real sequence: error handling, arrays,
/// procedures with parameters, locals and results, SELECT CASE, DO loops, strings, the wafer
/// map, blended moves with per-statement options.
fn sequence(lines: usize) -> String {
    let mut src = String::from(
        "' generated benchmark sequence\nDIM done[100]\nDIM names$[100]\nDIM stops[10] AS POSE\ntotal = 0\n",
    );
    let mut k = 0;
    while src.lines().count() < lines.saturating_sub(12) {
        let x = 220 + (k % 80);
        let y = -100 + (k % 200);
        let slot = 1 + k % 25;
        src.push_str(&format!(
            "FUNCTION move{k}(station$, n, dz) AS BOOLEAN\n\
             \x20 LOCAL tries = 0\n\
             \x20 LOCAL at = POSE({x}, {y}, 10, {yaw})\n\
             \x20 TRY\n\
             \x20   IF SLOT(station$, n) <> 1 THEN\n\
             \x20     RETURN FALSE\n\
             \x20   ENDIF\n\
             \x20   GET station$, n\n\
             \x20   MOVEL at + POSE(0, 0, dz, 0) SPEED 50 BLEND 5\n\
             \x20   MOVEL at SPEED 20 ACCEL 50\n\
             \x20 CATCH 212\n\
             \x20   tries = tries + 1\n\
             \x20   RESET\n\
             \x20   IF tries < 2 THEN\n\
             \x20     RETRY\n\
             \x20   ENDIF\n\
             \x20   ALARM 1001, \"miss at \" + station$ + \" slot \" + STR$(n)\n\
             \x20   WAIT OPERATOR \"check \" + station$\n\
             \x20   RETRY\n\
             \x20 CATCH 131, 136\n\
             \x20   RETURN FALSE\n\
             \x20 ENDTRY\n\
             \x20 RETURN TRUE\n\
             ENDFUNCTION\n\
             SELECT CASE {k} MOD 3\n\
             CASE 0\n\
             \x20 ok = move{k}(\"LP1\", {slot}, 20)\n\
             CASE 1, 2\n\
             \x20 ok = move{k}(\"LP2\", {slot}, 30)\n\
             CASE ELSE\n\
             \x20 ok = FALSE\n\
             END SELECT\n\
             IF ok THEN\n\
             \x20 done[{idx}] = done[{idx}] + 1\n\
             \x20 names$[{idx}] = WAFER$(\"LP2\", {slot}) + FORMAT$(total, \"000\")\n\
             \x20 total = total + 1\n\
             ENDIF\n\
             i = 0\n\
             DO\n\
             \x20 i = i + 1\n\
             \x20 stops[i MOD 10] = HERE() + POSE(i, 0, 0, 0)\n\
             LOOP UNTIL i >= 3\n\
             PRINT \"step {k}:\", names$[{idx}], LEN(names$[{idx}]), stops[1].X\n",
            yaw = k % 90,
            idx = k % 100,
        ));
        k += 1;
    }
    src.push_str("END\n");
    src
}

struct Io;

impl VmIo for Io {
    fn input(&self, _n: u8) -> bool {
        true
    }
    fn here(&self) -> Pose {
        Pose::default()
    }
}

fn bench(c: &mut Criterion) {
    let robot = Robot::paper_default();
    let src = program(10_000);
    let lines = src.lines().count();
    assert!(lines >= 9_900, "{lines} lines");
    let compiled = compile(&src, "bench.wrl", &robot);
    assert_eq!(
        compiled.errors(),
        0,
        "{}",
        compiled.render("bench.wrl", &src)
    );

    let seq = sequence(10_000);
    let lines = seq.lines().count();
    assert!(lines >= 9_900, "{lines} lines");
    let compiled = compile(&seq, "sequence.wrl", &robot);
    assert!(
        compiled.diagnostics.is_empty(),
        "{}",
        compiled.render("sequence.wrl", &seq)
    );

    let mut group = c.benchmark_group("compile");
    group.measurement_time(Duration::from_secs(12));
    group.sample_size(20);
    group.bench_function("10000_lines", |b| {
        b.iter(|| compile(black_box(&src), "bench.wrl", &robot))
    });
    group.bench_function("10000_lines_sequence", |b| {
        b.iter(|| compile(black_box(&seq), "sequence.wrl", &robot))
    });
    group.finish();

    // The VM: a loop of arithmetic and pose fields, 1000 instructions per run call.
    let vm_src = "N = 0\nP = POSE(300, 0, 0, 0)\nWHILE TRUE\n  N = N + P.X * 2 - SQRT(16)\n  IF N > 1000000 THEN\n    N = 0\n  ENDIF\nENDWHILE\n";
    let program = compile(vm_src, "vm.wrl", &robot)
        .program
        .expect("the VM benchmark compiles");
    let mut vm = Vm::new(VmLimits::default());
    vm.load(&program).expect("fits");
    c.bench_function("vm/1000_instructions", |b| {
        b.iter(|| match vm.run(&program, 1000, &mut Io) {
            Step::Budget => {}
            other => {
                vm.resume(Resume::Ok);
                black_box(other);
            }
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
