//! Controller integration tests, one module per topic.

mod alloc;
mod ethernet;
mod pipeline;
