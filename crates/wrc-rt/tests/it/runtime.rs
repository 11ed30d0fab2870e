//! Real threads: tasks run near their periods (loose bounds: a noisy 2-core VM), statistics
//! are plausible, start-up says what scheduling it got, overruns are reported, stop works.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use wrc_rt::ipc::MessageQueue;
use wrc_rt::wake::Wake;
use wrc_rt::{
    CycleContext, Notice, PinPolicy, RealtimeMode, Release, Runtime, RuntimeError, RuntimeOptions,
    Summary, Task, TaskSpec,
};

fn options(realtime: RealtimeMode) -> (RuntimeOptions, Arc<Mutex<Vec<Notice>>>) {
    let seen = Arc::new(Mutex::new(Vec::new()));
    let sink = seen.clone();
    let opts = RuntimeOptions {
        realtime,
        pin: PinPolicy::None,
        lock_memory_bytes: 0,
        report_interval_ms: 50,
        notices: Arc::new(move |n: &Notice| sink.lock().unwrap().push(n.clone())),
        ..RuntimeOptions::default()
    };
    (opts, seen)
}

#[test]
fn tasks_run_near_their_periods_with_plausible_stats() {
    let (opts, seen) = options(RealtimeMode::Off);
    let mut rt = Runtime::new(opts);
    rt.add(TaskSpec::new("fast", 20, 2_000), |_: &CycleContext| {
        std::hint::black_box(())
    });
    rt.add(TaskSpec::new("slow", 45, 10_000), |_: &CycleContext| {
        std::thread::sleep(Duration::from_micros(200))
    });
    let running = rt.start().unwrap();
    std::thread::sleep(Duration::from_millis(400));
    let live = running.snapshot();
    let report = running.stop(Duration::from_secs(2));
    assert!(report.is_clean(), "{report}");
    assert!(live.iter().all(|t| t.stats.cycles > 0));
    for (name, period_us, expected) in [("fast", 2_000.0, 200.0), ("slow", 10_000.0, 40.0)] {
        let t = report.tasks.iter().find(|t| t.spec.name == name).unwrap();
        let cycles = t.stats.cycles as f64;
        assert!(
            cycles >= expected * 0.3 && cycles <= expected * 1.3,
            "{name}: {cycles} cycles, expected ~{expected}"
        );
        let period = Summary::of(&t.stats.period);
        assert!(
            period.avg_us > period_us * 0.5 && period.avg_us < period_us * 2.0,
            "{name}: {period:?}"
        );
        assert!(
            period.min_us > 0.0 && period.min_us <= period.avg_us && period.avg_us <= period.max_us
        );
        assert_eq!(t.stats.exec.count(), t.stats.cycles);
    }
    let slow = report.tasks.iter().find(|t| t.spec.name == "slow").unwrap();
    assert!(
        Summary::of(&slow.stats.exec).min_us >= 200.0,
        "sleeping 200 µs takes at least 200 µs"
    );
    // Exactly one start-up statement, and it says normal scheduling was asked for.
    let notices = seen.lock().unwrap();
    let sched: Vec<_> = notices
        .iter()
        .filter(|n| matches!(n, Notice::Scheduling(_)))
        .collect();
    assert_eq!(sched.len(), 1);
    assert!(
        sched[0].to_string().contains("NOT real-time"),
        "{}",
        sched[0]
    );
}

#[test]
fn realtime_auto_runs_whatever_the_machine_allows_and_says_so_once() {
    let (opts, seen) = options(RealtimeMode::Auto);
    let mut rt = Runtime::new(opts);
    rt.add(
        TaskSpec::new("pulse_generator", 20, 1_000),
        |_: &CycleContext| {},
    );
    let running = rt.start().unwrap();
    let realtime = running.scheduling().is_realtime();
    std::thread::sleep(Duration::from_millis(100));
    let report = running.stop(Duration::from_secs(2));
    assert!(report.is_clean());
    assert!(report.tasks[0].stats.cycles > 10);
    let notices = seen.lock().unwrap();
    let text: Vec<String> = notices
        .iter()
        .filter(|n| matches!(n, Notice::Scheduling(_)))
        .map(|n| n.to_string())
        .collect();
    assert_eq!(text.len(), 1);
    if realtime {
        assert!(
            text[0].contains("SCHED_FIFO for all 1 tasks (priorities 70..70)"),
            "{}",
            text[0]
        );
    } else {
        assert!(text[0].contains("NOT real-time"), "{}", text[0]);
    }
}

#[test]
fn overruns_are_counted_and_reported_from_outside_the_task() {
    let (opts, seen) = options(RealtimeMode::Off);
    let mut rt = Runtime::new(opts);
    // Every 4th cycle takes 3 ms of a 1 ms period.
    rt.add(TaskSpec::new("late", 20, 1_000), |ctx: &CycleContext| {
        if ctx.cycle % 4 == 0 {
            std::thread::sleep(Duration::from_millis(3));
        }
    });
    let running = rt.start().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let report = running.stop(Duration::from_secs(2));
    let stats = &report.tasks[0].stats;
    assert!(stats.overruns >= 5, "{} overruns", stats.overruns);
    assert!(
        stats.missed_periods >= stats.overruns * 2,
        "missed {} for {} overruns",
        stats.missed_periods,
        stats.overruns
    );
    // Skipped periods are not replayed: cycles + missed periods roughly fill the time.
    let notices = seen.lock().unwrap();
    let reported: u64 = notices
        .iter()
        .map(|n| match n {
            Notice::Overruns { task, count, .. } if task == "late" => *count,
            _ => 0,
        })
        .sum();
    assert_eq!(
        reported, stats.overruns,
        "every overrun is reported exactly once"
    );
}

#[test]
fn stop_names_a_task_that_does_not_stop() {
    let (opts, _) = options(RealtimeMode::Off);
    let mut rt = Runtime::new(opts);
    rt.add(TaskSpec::new("good", 20, 1_000), |_: &CycleContext| {});
    rt.add(TaskSpec::new("stuck", 30, 1_000), |ctx: &CycleContext| {
        if ctx.cycle == 3 {
            std::thread::sleep(Duration::from_secs(3));
        }
    });
    let running = rt.start().unwrap();
    std::thread::sleep(Duration::from_millis(50));
    let t0 = Instant::now();
    let report = running.stop(Duration::from_millis(300));
    assert!(t0.elapsed() < Duration::from_secs(2));
    assert_eq!(report.not_stopped, ["stuck"]);
    assert!(
        report
            .to_string()
            .contains("stuck did not stop within 300 ms"),
        "{report}"
    );
}

#[test]
fn a_failed_setup_stops_everything_and_names_the_task() {
    struct Broken;
    impl Task for Broken {
        fn setup(&mut self) -> Result<(), wrc_rt::SetupError> {
            Err("device /dev/board0 missing".into())
        }
        fn cycle(&mut self, _: &CycleContext) {}
    }
    let (opts, _) = options(RealtimeMode::Off);
    let mut rt = Runtime::new(opts);
    rt.add(TaskSpec::new("fine", 20, 1_000), |_: &CycleContext| {});
    rt.add(TaskSpec::new("board", 20, 1_000), Broken);
    match rt.start() {
        Err(e @ RuntimeError::Setup { .. }) => {
            assert!(
                e.to_string().contains("board") && e.to_string().contains("/dev/board0"),
                "{e}"
            )
        }
        other => panic!("expected a setup error, got {other:?}"),
    }
}

#[test]
fn a_message_releases_its_consumer_long_before_its_period_and_stop_ends_the_wait() {
    let (opts, _) = options(RealtimeMode::Off);
    let mut rt = Runtime::new(opts);
    let wake = Wake::new();
    let requests = Arc::new(MessageQueue::with_notify(16, wake.notifier()));
    let replies = Arc::new(MessageQueue::new(16));
    let task = {
        let (requests, replies) = (requests.clone(), replies.clone());
        move |ctx: &CycleContext| {
            while let Ok(n) = requests.try_recv() {
                let _ = replies.try_send((n, ctx.release));
            }
        }
    };
    // A one-minute period: a reply within the test's run can only come from an event.
    rt.add_released(TaskSpec::new("echo", 45, 60_000_000), task, wake);
    let running = rt.start().unwrap();
    let t0 = Instant::now();
    let mut by_event = 0;
    for n in 0..20u32 {
        requests.try_send(n).unwrap();
        // The timeout only bounds a failure.
        let (echo, release) = replies.recv_timeout(Duration::from_secs(20)).unwrap();
        assert_eq!(echo, n);
        by_event += (release == Release::Event) as u32;
    }
    assert!(t0.elapsed() < Duration::from_secs(60), "not event-released");
    // The first request may have met the first grid point (the common origin).
    assert!(by_event >= 19, "{by_event} of 20 released by an event");
    let live = running.snapshot();
    // A cycle may pick up the next request too (it drains the queue), so there may be fewer
    // event cycles than requests, but there are some, counted apart from the periodic ones.
    assert!(live[0].stats.event_cycles >= 1);
    assert_eq!(live[0].stats.event_exec.count(), live[0].stats.event_cycles);
    // At most the first cycle at the grid origin was periodic.
    assert!(live[0].stats.cycles <= 1);
    // The waiting task is woken by the stop, not left until its next minute.
    let report = running.stop(Duration::from_secs(20));
    assert!(report.is_clean(), "{report}");
}
