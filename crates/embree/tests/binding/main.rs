//! The Embree binding against Embree itself: known answers, packets against
//! single rays, threads, and errors as values. One binary, so the Embree 4
//! leg builds and runs it without the renderer.

mod support;

mod camera_only;
mod device_errors;
mod errors;
mod packet_consistency;
mod single_triangle;
mod threads;
