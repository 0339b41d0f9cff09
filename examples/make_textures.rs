//! Generates the small procedural textures used by `scenes/room.toml` and by
//! the built-in scene `scenes/default.toml`:
//!
//! ```text
//! cargo run --release --example make_textures   # writes scenes/textures/*.png
//! ```
//!
//! A 4x4 tile floor, 256x256 each:
//! - `tiles_diffuse.png`  sRGB colour: two alternating dark stone tones, light grout
//!   (dark polished stone, so the glossy reflection of the lights is what the floor
//!   shows, not its diffuse colour).
//! - `tiles_roughness.png` linear grey: polished tiles (0.16 / 0.24), rough grout (0.9),
//!   with a low-frequency smudge so highlights vary within a tile.
//! - `tiles_normal.png`   tangent-space normals, +Y up (OpenGL): grooves at the grout
//!   lines and a gentle bevel, from finite differences of a height field.
//!
//! For the built-in scene, one map for its floor strips (each strip's quad maps the
//! whole image, 1.2 x 7.2 scene units):
//! - `showcase_normal.png` tangent-space normals, 384x64: a row of 6 square tiles with
//!   a bevel and a groove, each tile tilted by up to 0.03 in slope (from a hash of
//!   its index) so that a glossy reflection breaks from tile to tile.
//!
//! Deterministic (no random numbers), so regenerating gives identical files.

use image::{GrayImage, Luma, Rgb, RgbImage};
use std::path::Path;

const N: u32 = 256;
const TILES: f32 = 4.0;
/// Grout half-width, in tile units.
const GROUT: f32 = 0.04;

/// Distance (tile units) from (x, y) in texture units to the nearest grout line,
/// and the tile's integer coordinates.
fn tile(x: f32, y: f32) -> (f32, i32, i32) {
    let (tx, ty) = (x * TILES, y * TILES);
    let (fx, fy) = (tx.fract(), ty.fract());
    let d = fx.min(1.0 - fx).min(fy.min(1.0 - fy));
    (d, tx.floor() as i32, ty.floor() as i32)
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Height in [0, 1]: 0 in the grout, rising over a bevel to 1 on the tile top.
fn height(x: f32, y: f32) -> f32 {
    let (d, _, _) = tile(x.rem_euclid(1.0), y.rem_euclid(1.0));
    smoothstep(GROUT, GROUT + 0.06, d)
}

/// Texel centre in texture units, row 0 at the top (t = 1 - row).
fn uv(i: u32, j: u32) -> (f32, f32) {
    (
        (i as f32 + 0.5) / N as f32,
        1.0 - (j as f32 + 0.5) / N as f32,
    )
}

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/textures");
    std::fs::create_dir_all(&dir).expect("create scenes/textures");

    let diffuse = RgbImage::from_fn(N, N, |i, j| {
        let (s, t) = uv(i, j);
        let (d, tx, ty) = tile(s, t);
        if d < GROUT {
            Rgb([150, 144, 134])
        } else if (tx + ty) % 2 == 0 {
            Rgb([46, 44, 42])
        } else {
            Rgb([78, 56, 42])
        }
    });
    diffuse
        .save(dir.join("tiles_diffuse.png"))
        .expect("write diffuse");

    let roughness = GrayImage::from_fn(N, N, |i, j| {
        let (s, t) = uv(i, j);
        let (d, tx, ty) = tile(s, t);
        let r = if d < GROUT {
            0.9
        } else {
            let base = if (tx + ty) % 2 == 0 { 0.16 } else { 0.24 };
            let smudge = 0.03 * (s * 9.0).sin() * (t * 7.0).cos();
            base + smudge
        };
        Luma([(r.clamp(0.0, 1.0) * 255.0).round() as u8])
    });
    roughness
        .save(dir.join("tiles_roughness.png"))
        .expect("write roughness");

    // Slope scale: height units per texture unit; larger = deeper grooves.
    let depth = 0.02;
    let h = 1.0 / N as f32;
    let normal = RgbImage::from_fn(N, N, |i, j| {
        let (s, t) = uv(i, j);
        let dhds = (height(s + h, t) - height(s - h, t)) / (2.0 * h) * depth;
        let dhdt = (height(s, t + h) - height(s, t - h)) / (2.0 * h) * depth;
        let (nx, ny, nz) = (-dhds, -dhdt, 1.0f32);
        let len = (nx * nx + ny * ny + nz * nz).sqrt();
        let enc = |c: f32| ((c / len * 0.5 + 0.5) * 255.0).round() as u8;
        Rgb([enc(nx), enc(ny), enc(nz)])
    });
    normal
        .save(dir.join("tiles_normal.png"))
        .expect("write normal");

    showcase_normal()
        .save(dir.join("showcase_normal.png"))
        .expect("write showcase normal");
    println!("wrote {}", dir.display());
}

/// Size of `showcase_normal.png` and its tiles: 6 along s, 1 along t, so the
/// tiles are square on a 1.2 x 7.2 strip.
const SHOWCASE_W: u32 = 384;
const SHOWCASE_H: u32 = 64;
const SHOWCASE_TILES_S: f64 = 6.0;
/// Groove half-width and bevel width, in tile units.
const SHOWCASE_GROOVE: f64 = 0.035;
const SHOWCASE_BEVEL: f64 = 0.05;
/// Slope per unit of height (per tile width): the bevel's steepest slope is about 0.6.
const SHOWCASE_DEPTH: f64 = 0.02;
/// Largest per-tile tilt, as a slope along each axis.
const SHOWCASE_TILT: f64 = 0.03;

/// Height of the showcase tiles at texture coordinates (s, t), in units the
/// normal's slopes are taken in (see `SHOWCASE_DEPTH`).
fn showcase_height(s: f64, t: f64) -> f64 {
    let (s, t) = (s.rem_euclid(1.0), t.rem_euclid(1.0));
    let (fs, ft) = ((s * SHOWCASE_TILES_S).fract(), t);
    let d = fs.min(1.0 - fs).min(ft.min(1.0 - ft));
    let x = ((d - SHOWCASE_GROOVE) / SHOWCASE_BEVEL).clamp(0.0, 1.0);
    let bevel = x * x * (3.0 - 2.0 * x);
    // Per-tile tilt from an integer hash of the tile's index: two slopes in [-1, 1].
    let tile = (s * SHOWCASE_TILES_S) as u32;
    let hash = ((tile.wrapping_mul(73_856_093)) ^ 0x5bd1_e995).wrapping_mul(2_654_435_761);
    let ax = (hash & 0xffff) as f64 / 65535.0 * 2.0 - 1.0;
    let ay = (hash >> 16) as f64 / 65535.0 * 2.0 - 1.0;
    let tilt = SHOWCASE_TILT / SHOWCASE_DEPTH * (ax * (fs - 0.5) + ay * (ft - 0.5));
    bevel * (1.0 + tilt)
}

fn showcase_normal() -> RgbImage {
    let (hs, ht) = (1.0 / SHOWCASE_W as f64, 1.0 / SHOWCASE_H as f64);
    RgbImage::from_fn(SHOWCASE_W, SHOWCASE_H, |i, j| {
        let s = (i as f64 + 0.5) * hs;
        let t = 1.0 - (j as f64 + 0.5) * ht;
        // Slopes per tile width: s spans 6 tiles, t one.
        let dhds = (showcase_height(s + hs, t) - showcase_height(s - hs, t))
            / (2.0 * hs)
            / SHOWCASE_TILES_S
            * SHOWCASE_DEPTH;
        let dhdt =
            (showcase_height(s, t + ht) - showcase_height(s, t - ht)) / (2.0 * ht) * SHOWCASE_DEPTH;
        let (nx, ny, nz) = (-dhds, -dhdt, 1.0f64);
        let len = (nx * nx + ny * ny + nz * nz).sqrt();
        let enc = |c: f64| ((c / len * 0.5 + 0.5) * 255.0).round() as u8;
        Rgb([enc(nx), enc(ny), enc(nz)])
    })
}
