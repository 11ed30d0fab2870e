//! Controller integration tests, one module per topic.

mod pipeline;
