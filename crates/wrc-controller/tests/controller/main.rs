//! Controller integration tests, one module per topic.

mod alloc;
mod error_check;
mod ethernet;
mod pipeline;
