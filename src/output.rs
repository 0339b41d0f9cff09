//! Frames to files: EXR keeps linear radiance, PNG the display transform
//! (`display`). Also the extra AOV files written beside the main image.

use crate::display::DisplayMap;
use crate::render::{Frame, PixelKind};
use glam::Vec3;
use image::{ImageBuffer, Rgb};
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: unsupported output format (use .png or .exr)")]
    Format { path: PathBuf },
    #[error("{path}: {source}")]
    Write {
        path: PathBuf,
        source: image::ImageError,
    },
    #[error("unknown AOV \"{0}\" (expected any of: {names})", names = Aov::ALL.map(|a| a.name()).join(", "))]
    UnknownAov(String),
}

/// Extra images a render can write beside its main output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Aov {
    Albedo,
    Normal,
    Depth,
    U,
    Un,
    Sn,
    Ratio,
}

impl Aov {
    pub const ALL: [Aov; 7] = [
        Aov::Albedo,
        Aov::Normal,
        Aov::Depth,
        Aov::U,
        Aov::Un,
        Aov::Sn,
        Aov::Ratio,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::U => "u",
            Aov::Un => "un",
            Aov::Sn => "sn",
            Aov::Ratio => "ratio",
        }
    }

    /// Parses a comma-separated list such as `albedo,depth`.
    pub fn parse_list(list: &str) -> Result<Vec<Aov>, OutputError> {
        list.split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|s| {
                Aov::ALL
                    .into_iter()
                    .find(|a| a.name() == s)
                    .ok_or_else(|| OutputError::UnknownAov(s.to_string()))
            })
            .collect()
    }

    /// The AOV's value per pixel: linear data, no tonemapping.
    pub fn values(self, frame: &Frame) -> Vec<Vec3> {
        let n = frame.pixel_count();
        (0..n)
            .map(|k| {
                let g = &frame.gbuf[k];
                let surface = g.kind == PixelKind::Surface;
                match self {
                    Aov::Albedo if surface => g.diffuse,
                    Aov::Albedo => Vec3::ZERO,
                    Aov::Normal if g.kind != PixelKind::Miss => g.ns,
                    Aov::Normal => Vec3::ZERO,
                    Aov::Depth => Vec3::splat(g.depth),
                    Aov::U => frame.u[k],
                    Aov::Un => frame.un[k],
                    Aov::Sn => frame.sn[k],
                    Aov::Ratio => crate::render::estimate::ratio(frame.sn[k], frame.un[k]),
                }
            })
            .collect()
    }
}

/// `out.png` + `depth` → `out.depth.exr`.
pub fn aov_path(out: &Path, aov: Aov) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    out.with_file_name(format!("{stem}.{}.exr", aov.name()))
}

/// Writes linear values as EXR (32-bit float RGB). Non-finite values are
/// written as 0 so no file ever carries a NaN.
pub fn write_exr(path: &Path, width: u32, height: u32, pixels: &[Vec3]) -> Result<(), OutputError> {
    let data: Vec<f32> = pixels
        .iter()
        .flat_map(|c| {
            let c = crate::render::frame::finite_or_zero(*c);
            [c.x, c.y, c.z]
        })
        .collect();
    let img: ImageBuffer<Rgb<f32>, Vec<f32>> =
        ImageBuffer::from_raw(width, height, data).expect("buffer size matches width * height");
    img.save_with_format(path, image::ImageFormat::OpenExr)
        .map_err(|source| OutputError::Write {
            path: path.to_path_buf(),
            source,
        })
}

pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[Vec3],
    exposure: f32,
) -> Result<(), OutputError> {
    let map = DisplayMap::new(exposure.exp2());
    let data: Vec<u8> = pixels.iter().flat_map(|c| map.rgb8(*c)).collect();
    let img: ImageBuffer<Rgb<u8>, Vec<u8>> =
        ImageBuffer::from_raw(width, height, data).expect("buffer size matches width * height");
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|source| OutputError::Write {
            path: path.to_path_buf(),
            source,
        })
}

/// Writes linear radiance as PNG (tonemapped, with `exposure` in stops) or
/// EXR, by `path`'s extension.
pub fn write_color(
    path: &Path,
    width: u32,
    height: u32,
    color: &[Vec3],
    exposure: f32,
) -> Result<(), OutputError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("png") => write_png(path, width, height, color, exposure),
        Some("exr") => write_exr(path, width, height, color),
        _ => Err(OutputError::Format {
            path: path.to_path_buf(),
        }),
    }
}

/// Writes the frame's colour to `path` (format from the extension) and each
/// AOV beside it as EXR. Returns the paths written.
pub fn write_frame(
    path: &Path,
    frame: &Frame,
    exposure: f32,
    aovs: &[Aov],
) -> Result<Vec<PathBuf>, OutputError> {
    write_color(path, frame.width, frame.height, &frame.color, exposure)?;
    let mut written = vec![path.to_path_buf()];
    for &aov in aovs {
        let p = aov_path(path, aov);
        write_exr(&p, frame.width, frame.height, &aov.values(frame))?;
        written.push(p);
    }
    Ok(written)
}
