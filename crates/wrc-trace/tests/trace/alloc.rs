//! Zero allocation when the real-time tasks push: samples and messages, into a ring that is
//! filling and into one that is full and overwrites.

use wrc_alloc_count::allocations_in;
use wrc_trace::{Direction, Message, Ring, Sample, MAX_MESSAGE};

#[test]
fn pushes_allocate_nothing_while_filling_and_when_full() {
    wrc_alloc_count::assert_installed();
    let mut ring = Ring::new(100, 20);
    let long = [b'L'; MAX_MESSAGE + 40];
    let (calls, ()) = allocations_in(|| {
        for k in 0..1_000u64 {
            let mut s = Sample {
                t_ns: k,
                ..Sample::default()
            };
            s.commanded[15] = k as i64;
            ring.push_sample(&s);
            let line: &[u8] = if k % 2 == 0 { b"STATUS\n" } else { &long };
            ring.push_message(&Message::new(k, Direction::Request, 0, 1, line));
        }
    });
    assert_eq!(calls.total(), 0, "{calls:?} in 1000 pushes");
    assert_eq!(ring.len().samples, 100);
    assert_eq!(ring.samples().next().map(|s| s.t_ns), Some(900));
    assert_eq!(ring.overwritten().messages, 980);
}

#[test]
fn reading_the_ring_allocates_nothing() {
    wrc_alloc_count::assert_installed();
    let mut ring = Ring::new(8, 8);
    for k in 0..13 {
        ring.push_sample(&Sample {
            t_ns: k,
            ..Sample::default()
        });
    }
    let (calls, sum) = allocations_in(|| ring.samples().map(|s| s.t_ns).sum::<u64>());
    assert_eq!(calls.total(), 0);
    assert_eq!(sum, (5..13).sum::<u64>());
}
