//! Integration tests of the protocol crate, one module per topic, compiled as one test
//! binary. The binary counts heap allocations per thread so that [`alloc`] can prove that
//! framing, parsing, formatting and encoding allocate nothing.

mod alloc;
mod session;
mod vectors;
