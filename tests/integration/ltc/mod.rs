//! The analytic unshadowed light U (LTC) against brute-force quadrature, scalar and batched.

mod accuracy;
mod hard_cases;
mod image_accuracy;
mod light_bound;
mod many_lights_image;
mod properties;
mod table;
mod u_batch;
mod unshadowed_mode;
mod validation;
