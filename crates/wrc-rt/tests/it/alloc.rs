//! Zero allocation in the per-cycle path: the driver's step (sleep, cycle, statistics,
//! overrun event) and the IPC a cycle uses, with real and mock clocks.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use wrc_rt::bench::work::{Role, SyntheticTask};
use wrc_rt::ipc::{self, MessageQueue, Semaphore};
use wrc_rt::{Clock, CycleContext, MockClock, MonotonicClock, StatsCell, Step, TaskDriver};

use wrc_alloc_count::allocations_in;

#[test]
fn driver_steps_allocate_nothing_with_the_real_clock() {
    wrc_alloc_count::assert_installed();
    // Everything a cycle may touch is created here, before counting starts.
    let sem = Arc::new(Semaphore::new(0));
    let queue = Arc::new(MessageQueue::<[u64; 4]>::new(8));
    let (mut spsc_tx, mut spsc_rx) = ipc::spsc::channel::<[i32; 4]>(8);
    let (mut mb_w, mut mb_r) = ipc::mailbox([0i64; 4]);
    let task = {
        let (sem, queue) = (sem.clone(), queue.clone());
        move |ctx: &CycleContext| {
            sem.post();
            assert!(sem.try_wait());
            let _ = queue.try_send([ctx.cycle; 4]);
            let _ = queue.try_recv();
            let _ = spsc_tx.try_send([1, 2, 3, 4]);
            let _ = spsc_rx.try_recv();
            mb_w.write([ctx.cycle as i64; 4]);
            std::hint::black_box(mb_r.read());
        }
    };
    let stats = Arc::new(StatsCell::new());
    let (tx, _rx) = rtrb::RingBuffer::new(4);
    let clock = MonotonicClock;
    let mut driver = TaskDriver::new(
        clock,
        task,
        clock.now_ns() + 1_000_000,
        200_000,
        stats.clone(),
        tx,
        Arc::new(AtomicBool::new(false)),
    );
    let (n, ()) = allocations_in(|| {
        for _ in 0..300 {
            assert_eq!(driver.step(), Step::Ran);
        }
    });
    assert_eq!(n.total(), 0, "{n:?} in 300 cycles");
    assert_eq!(stats.snapshot().cycles, 300);
}

#[test]
fn overruns_and_a_full_event_queue_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let clock = MockClock::new(0);
    let c = clock.clone();
    // Every cycle overruns; the event queue (capacity 2) fills up after two.
    let task = move |_: &CycleContext| c.advance_ns(2_500);
    let stats = Arc::new(StatsCell::new());
    let (tx, _rx) = rtrb::RingBuffer::new(2);
    let mut driver = TaskDriver::new(
        clock,
        task,
        1_000,
        1_000,
        stats.clone(),
        tx,
        Arc::new(AtomicBool::new(false)),
    );
    let (n, ()) = allocations_in(|| {
        for _ in 0..1000 {
            driver.step();
        }
    });
    assert_eq!(n.total(), 0, "{n:?}");
    let s = stats.snapshot();
    assert_eq!((s.overruns, s.missed_periods), (1000, 2000));
}

#[test]
fn the_benchmark_tasks_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let (tx, rx) = ipc::spsc::channel(16);
    let (w, r) = ipc::mailbox([0i64; 4]);
    let mut tasks = [
        SyntheticTask::new(1, 3, 1, Role::VelocityGenerator(tx, 5)),
        SyntheticTask::new(1, 3, 2, Role::PulseGenerator(rx, w)),
        SyntheticTask::new(1, 3, 3, Role::SimulatorManager(r)),
        SyntheticTask::new(1, 3, 4, Role::Plain),
    ];
    let (n, ()) = allocations_in(|| {
        for cycle in 0..100 {
            for t in tasks.iter_mut() {
                let now = MonotonicClock.now_ns();
                let ctx = CycleContext {
                    cycle,
                    scheduled_ns: now,
                    woke_ns: now,
                    period_ns: 1_000_000,
                };
                wrc_rt::Task::cycle(t, &ctx);
            }
        }
    });
    assert_eq!(n.total(), 0, "{n:?}");
}
