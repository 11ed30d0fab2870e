//! Integration tests of the velocity generator, one module per topic, compiled as one test
//! binary. The binary counts heap allocations per thread so that [`alloc`] can prove that
//! planning and producing periods allocate nothing.

mod alloc;
mod approach;
mod blend;
mod common;
mod line;
mod path;
mod ptp;
mod ruckig;
mod stop;
