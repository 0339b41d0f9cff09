//! Light and BRDF sampling, MIS and the low-discrepancy sequence against f64 references.

mod brdf;
mod draw_lanes;
mod light;
mod light_sampler;
mod mis;
mod properties;
mod sequence;
mod trig;
