//! Integration tests of the robot language, one module per topic, compiled as one test
//! binary. The binary counts heap allocations per thread so that [`alloc`] can prove that
//! loading and running a program allocate nothing.

mod alloc;
mod common;
mod docs;
mod examples;
mod golden;
mod requests;
mod robustness;
mod roundtrip;
mod transfer;
mod vm;
