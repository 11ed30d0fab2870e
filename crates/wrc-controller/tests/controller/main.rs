//! Controller integration tests, one module per topic.

mod alloc;
mod error_check;
mod estop_input;
mod ethernet;
mod motion;
mod pipeline;
mod stop_end;
mod virtual_time;
