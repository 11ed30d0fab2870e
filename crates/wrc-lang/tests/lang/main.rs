//! Integration tests of the robot language, one module per topic, compiled as one test
//! binary. The binary counts heap allocations per thread so that [`alloc`] can prove that
//! loading and running a program allocate nothing.

mod alloc;
mod cell;
mod common;
mod data;
mod debugger;
mod docs;
mod errors;
mod examples;
mod golden;
mod motion;
mod requests;
mod robustness;
mod roundtrip;
mod transfer;
mod vm;
