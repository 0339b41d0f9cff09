//! The penumbra binary end to end: render, frames, bad input, bench, progress output.

mod bad_input;
mod bench;
mod commands;
mod frames;
mod progress;
