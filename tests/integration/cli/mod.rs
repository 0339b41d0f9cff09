//! The penumbra binary end to end: render, frames, bad input, bench, progress output,
//! instruction-set levels.

mod bad_input;
mod bench;
mod commands;
mod frames;
mod isa;
mod progress;
