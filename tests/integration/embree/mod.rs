//! The Embree wrapper: known answers, packets against single rays, threads, and errors as values.

mod camera_only;
mod device_errors;
mod errors;
mod packet_consistency;
mod single_triangle;
mod threads;
