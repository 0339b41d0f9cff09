//! Every integration test in one binary: one link against the library
//! instead of one per file, and one test harness that runs all areas in
//! parallel. Each area is a module (`cargo test --release --test integration
//! denoise::` runs one); `support` holds the fixtures they share.

mod support;

mod cli;
mod compare;
mod denoise;
mod golden;
mod ltc;
mod render;
mod sampling;

mod view;
