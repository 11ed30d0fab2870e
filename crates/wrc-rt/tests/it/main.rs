//! wrc-rt integration tests: one binary, a module per topic. The binary's global allocator
//! counts heap calls per thread (`wrc_alloc_count`; see `alloc`).

mod alloc;
mod ipc_stress;
mod runtime;

use wrc_alloc_count::CountingAllocator;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;
