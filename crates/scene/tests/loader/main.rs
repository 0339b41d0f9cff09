//! The scene loader: TOML, OBJ, image maps, the shipped scenes, and every
//! refusal. One binary, built without the renderer.

mod support;

mod bad_files;
mod errors;
mod geometry;
mod obj;
mod robustness;
mod shipped;
mod textures;
