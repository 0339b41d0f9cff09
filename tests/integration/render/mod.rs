//! Frames: the G-buffer, determinism, the seed paper's claims, shadow budgets, visibility rate, settled tiles, the pixel replay, NaN sweeps, upscaled output.

mod determinism;
mod gbuffer;
mod light_culling;
mod nan_sweep;
mod no_specular_lobe;
mod pixel_replay;
mod seed_claims;
mod settle;
mod shadow_budget;
mod upscaled;
mod visibility_rate;
