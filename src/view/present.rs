//! Linear frame to window pixels, and window pixels to screenshot files.

use crate::display::DisplayMap;
use crate::output;
use anyhow::{Context, Result};
use glam::Vec3;
use image::{ImageBuffer, Rgb};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Tonemaps linear radiance into 0RGB window pixels with the same display
/// transform as PNG output. A pixel with any non-finite channel is shown
/// black: no NaN reaches the screen whatever the renderer hands over.
/// Returns how many pixels were non-finite, so the caller can say so.
pub fn to_display(color: &[Vec3], map: &DisplayMap, out: &mut [u32]) -> usize {
    assert_eq!(color.len(), out.len(), "frame and window sizes agree");
    out.par_iter_mut()
        .zip(color)
        .map(|(p, c)| {
            if !c.is_finite() {
                *p = 0;
                return 1;
            }
            let [r, g, b] = map.rgb8(*c);
            *p = (r as u32) << 16 | (g as u32) << 8 | b as u32;
            0
        })
        .sum()
}

/// Writes a screenshot: `png` gets exactly the window's pixels (overlay
/// included when it is shown), and the linear frame goes beside it as EXR
/// (`shot.png` -> `shot.exr`). Returns both paths.
pub fn save_screenshot(
    png: &Path,
    width: u32,
    height: u32,
    shown: &[u32],
    linear: &[Vec3],
) -> Result<[PathBuf; 2]> {
    let rgb: Vec<u8> = shown
        .iter()
        .flat_map(|p| [(p >> 16) as u8, (p >> 8) as u8, *p as u8])
        .collect();
    let img: ImageBuffer<Rgb<u8>, Vec<u8>> =
        ImageBuffer::from_raw(width, height, rgb).expect("buffer size matches width * height");
    img.save_with_format(png, image::ImageFormat::Png)
        .with_context(|| format!("{}: writing the screenshot", png.display()))?;
    let exr = png.with_extension("exr");
    output::write_exr(&exr, width, height, linear)?;
    Ok([png.to_path_buf(), exr])
}

/// The first `penumbra-NNN.png` in `dir` that does not exist yet.
pub fn next_screenshot_path(dir: &Path) -> PathBuf {
    (1u32..)
        .map(|n| dir.join(format!("penumbra-{n:03}.png")))
        .find(|p| !p.exists() && !p.with_extension("exr").exists())
        .expect("some number is free")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_pixels_are_shown_black_and_counted() {
        let color = [
            Vec3::new(f32::NAN, 0.5, 0.5),
            Vec3::splat(0.5),
            Vec3::new(0.5, f32::INFINITY, 0.5),
            Vec3::new(0.5, 0.5, f32::NEG_INFINITY),
        ];
        let mut out = [0x00ff_ffffu32; 4];
        assert_eq!(to_display(&color, &DisplayMap::new(1.0), &mut out), 3);
        assert_eq!([out[0], out[2], out[3]], [0, 0, 0]);
        let [r, g, b] = crate::display::display_rgb8(Vec3::splat(0.5), 1.0);
        assert_eq!(out[1], (r as u32) << 16 | (g as u32) << 8 | b as u32);
        assert_ne!(out[1], 0);
    }

    #[test]
    fn screenshot_names_count_up_past_existing_files() {
        let dir = tempfile::tempdir().unwrap();
        let first = next_screenshot_path(dir.path());
        assert_eq!(first.file_name().unwrap(), "penumbra-001.png");
        std::fs::write(dir.path().join("penumbra-001.exr"), b"").unwrap();
        assert_eq!(
            next_screenshot_path(dir.path()).file_name().unwrap(),
            "penumbra-002.png"
        );
    }
}
