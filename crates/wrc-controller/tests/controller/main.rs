//! Controller integration tests, one module per topic.

mod ethernet;
mod pipeline;
