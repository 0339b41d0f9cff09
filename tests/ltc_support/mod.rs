//! The brute-force U of the integration tests (`tests/integration/support/ltc.rs`)
//! for `examples/u_scene_error.rs`, which includes this file by path.
// The example uses `reference` alone.
#![allow(dead_code)]

#[path = "../integration/support/ltc.rs"]
mod ltc;

pub use ltc::*;
