//! A counting global allocator for wrc's tests: it proves that a real-time path allocates
//! and frees nothing. It forwards every call to the system allocator unchanged and counts,
//! per thread, the calls that take memory (`alloc`, `alloc_zeroed`, `realloc`) and the calls
//! that give it back (`dealloc`). Counting is per thread, so tests running in parallel on
//! other threads never disturb a count.
//!
//! A test binary installs it and measures the path under test:
//!
//! ```
//! use wrc_alloc_count::{allocations_in, CountingAllocator};
//!
//! #[global_allocator]
//! static GLOBAL: CountingAllocator = CountingAllocator;
//!
//! let mut buf = Vec::with_capacity(16); // set up before counting
//! let (calls, ()) = allocations_in(|| buf.extend_from_slice(&[1u8, 2, 3]));
//! assert_eq!(calls.total(), 0);
//! let (calls, v) = allocations_in(|| vec![0u8; 64]);
//! assert_eq!(calls.allocations, 1);
//! # drop(v);
//! ```
//!
//! Without `#[global_allocator]` in the test binary nothing is counted, so every test that
//! asserts zero should also assert, once, that the counter sees an allocation
//! ([`allocations_in`] of a `Vec`).
#![deny(missing_docs)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting heap calls per thread. Install it with
/// `#[global_allocator]` in a test binary.
pub struct CountingAllocator;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
    static FREES: Cell<u64> = const { Cell::new(0) };
}

fn bump(counter: &'static std::thread::LocalKey<Cell<u64>>) {
    // `try_with`: during thread teardown the counter may be gone; such calls are not counted.
    let _ = counter.try_with(|c| c.set(c.get() + 1));
}

// SAFETY: every call is forwarded unchanged to `System`, with the caller's guarantees.
// Counting touches only const-initialised thread-locals, which never allocate and never
// recurse into the allocator.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        bump(&ALLOCATIONS);
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        bump(&ALLOCATIONS);
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        bump(&FREES);
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        bump(&ALLOCATIONS);
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Heap calls made on one thread.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HeapCalls {
    /// Calls that took memory: `alloc`, `alloc_zeroed` and `realloc`.
    pub allocations: u64,
    /// Calls that gave memory back: `dealloc`.
    pub frees: u64,
}

impl HeapCalls {
    /// Every heap call, taking or giving back.
    pub fn total(self) -> u64 {
        self.allocations + self.frees
    }

    /// The calls made since `earlier` (a count taken before on the same thread).
    pub fn since(self, earlier: HeapCalls) -> HeapCalls {
        HeapCalls {
            allocations: self.allocations - earlier.allocations,
            frees: self.frees - earlier.frees,
        }
    }
}

/// The heap calls made on this thread so far.
pub fn heap_calls() -> HeapCalls {
    HeapCalls {
        allocations: ALLOCATIONS.with(Cell::get),
        frees: FREES.with(Cell::get),
    }
}

/// Run `f` and return the heap calls it made on this thread, with its result. Whatever `f`
/// returns is dropped by the caller, after counting.
pub fn allocations_in<R>(f: impl FnOnce() -> R) -> (HeapCalls, R) {
    let before = heap_calls();
    let r = f();
    (heap_calls().since(before), r)
}

/// Panics unless [`CountingAllocator`] is this test binary's global allocator. A test that
/// asserts zero heap calls calls it first, so that it cannot pass on a counter that never
/// counts.
pub fn assert_installed() {
    let (calls, v) = allocations_in(|| std::hint::black_box(vec![1u8; 64]));
    drop(v);
    assert!(
        calls.allocations >= 1,
        "wrc_alloc_count::CountingAllocator is not this binary's global allocator: \
         add `#[global_allocator] static GLOBAL: CountingAllocator = CountingAllocator;`"
    );
}

#[cfg(test)]
mod tests {
    // No global allocator is installed in this unit-test binary: nothing is counted.
    #[test]
    #[should_panic(expected = "is not this binary's global allocator")]
    fn assert_installed_fails_without_the_allocator() {
        super::assert_installed();
    }
}
