//! Image against reference: relMSE, mean FLIP, the largest absolute error
//! and where it is, the speckle count (isolated pixels off the reference by
//! more than 2x), an optional FLIP heat map; what `penumbra compare` prints
//! and what the golden-frame tests gate on.
//!
//! Both images are read as stored: EXR as linear radiance, PNG as its
//! display-encoded values scaled to [0, 1]. relMSE and the absolute error are
//! taken on those values, so an EXR and a PNG are never mixed. FLIP is the
//! LDR FLIP of `nv-flip` (NVIDIA's reference code), which takes sRGB images:
//! a PNG goes in as its bytes, an EXR through the renderer's own display
//! transform at exposure 0 (`display::DisplayMap`), as `render` would have
//! written it to PNG.

use crate::display::DisplayMap;
use crate::report::stats::rel_mse;
use glam::Vec3;
use image::ImageFormat;
use std::path::{Path, PathBuf};

/// Pixels per degree of visual angle FLIP assumes: its default (a 0.7 m
/// wide 4K monitor seen from 0.7 m).
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("{path}: {source}", path = path.display())]
    Read {
        path: PathBuf,
        source: image::ImageError,
    },
    #[error("{path}: not a .png or .exr file", path = path.display())]
    Format { path: PathBuf },
    #[error(
        "{a} is {aw}x{ah} but {b} is {bw}x{bh}: images of one size are needed",
        a = a.display(),
        b = b.display()
    )]
    Size {
        a: PathBuf,
        aw: u32,
        ah: u32,
        b: PathBuf,
        bw: u32,
        bh: u32,
    },
    #[error(
        "{a} is {ak} and {b} is {bk}: compare two EXR (linear) or two PNG (display) images",
        a = a.display(),
        b = b.display()
    )]
    Kind {
        a: PathBuf,
        ak: &'static str,
        b: PathBuf,
        bk: &'static str,
    },
    #[error("{path}: pixel ({x}, {y}) holds a value that is not finite", path = path.display())]
    NotFinite { path: PathBuf, x: u32, y: u32 },
    #[error("{path}: {source}", path = path.display())]
    Write {
        path: PathBuf,
        source: image::ImageError,
    },
}

/// How an image's values are to be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// Linear radiance (EXR).
    Linear,
    /// Display-encoded values in [0, 1] (PNG).
    Display,
}

impl Encoding {
    fn name(self) -> &'static str {
        match self {
            Encoding::Linear => "EXR (linear)",
            Encoding::Display => "PNG (display-encoded)",
        }
    }
}

/// An RGB image as compared: row-major, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
    pub encoding: Encoding,
    /// Where it was read from, for messages.
    pub path: PathBuf,
}

impl Image {
    /// A linear image held in memory (a rendered frame), named `path` in messages.
    pub fn linear(width: u32, height: u32, pixels: Vec<Vec3>, path: impl Into<PathBuf>) -> Image {
        assert_eq!(pixels.len(), (width * height) as usize, "pixel count");
        Image {
            width,
            height,
            pixels,
            encoding: Encoding::Linear,
            path: path.into(),
        }
    }

    /// Reads a .png or .exr file (format from the extension).
    pub fn load(path: &Path) -> Result<Image, CompareError> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let (format, encoding) = match ext.as_deref() {
            Some("exr") => (ImageFormat::OpenExr, Encoding::Linear),
            Some("png") => (ImageFormat::Png, Encoding::Display),
            _ => {
                return Err(CompareError::Format {
                    path: path.to_path_buf(),
                });
            }
        };
        let read = |source| CompareError::Read {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::open(path).map_err(|e| read(image::ImageError::IoError(e)))?;
        let img = image::load(std::io::BufReader::new(file), format).map_err(read)?;
        let rgb = img.into_rgb32f();
        let (width, height) = rgb.dimensions();
        let pixels: Vec<Vec3> = rgb.pixels().map(|p| Vec3::from_array(p.0)).collect();
        if let Some(k) = pixels.iter().position(|c| !c.is_finite()) {
            return Err(CompareError::NotFinite {
                path: path.to_path_buf(),
                x: k as u32 % width,
                y: k as u32 / width,
            });
        }
        Ok(Image {
            width,
            height,
            pixels,
            encoding,
            path: path.to_path_buf(),
        })
    }

    /// The image as FLIP reads it: sRGB, 8 bits per channel.
    fn srgb8(&self) -> Vec<u8> {
        match self.encoding {
            Encoding::Linear => {
                let map = DisplayMap::new(1.0);
                self.pixels.iter().flat_map(|c| map.rgb8(*c)).collect()
            }
            Encoding::Display => self
                .pixels
                .iter()
                .flat_map(|c| c.to_array())
                .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
                .collect(),
        }
    }
}

/// The pixel of the largest absolute error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Worst {
    pub x: u32,
    pub y: u32,
    pub test: Vec3,
    pub reference: Vec3,
}

/// A test image measured against a reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// mean((a - b)^2 / (b^2 + 1e-2)) over pixels and channels, `b` the reference.
    pub rel_mse: f64,
    /// Mean of FLIP's per-pixel error map, in [0, 1].
    pub mean_flip: f64,
    /// Largest |a - b| over pixels and channels.
    pub max_abs: f32,
    pub worst: Worst,
    /// Isolated outliers ([`speckles`]), with the pixels they are counted among.
    pub speckles: Speckles,
}

/// The gate a comparison must pass; `None` leaves a figure ungated.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Limits {
    pub max_rel_mse: Option<f64>,
    pub max_flip: Option<f64>,
}

impl Limits {
    /// The figures above their limits, as `name value > limit` lines (empty: passed).
    pub fn exceeded(&self, c: &Comparison) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(m) = self.max_rel_mse.filter(|&m| c.rel_mse > m) {
            out.push(format!("relMSE {:.6e} > {m:e}", c.rel_mse));
        }
        if let Some(m) = self.max_flip.filter(|&m| c.mean_flip > m) {
            out.push(format!("mean FLIP {:.6} > {m}", c.mean_flip));
        }
        out
    }
}

fn check_pair(test: &Image, reference: &Image) -> Result<(), CompareError> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(CompareError::Size {
            a: test.path.clone(),
            aw: test.width,
            ah: test.height,
            b: reference.path.clone(),
            bw: reference.width,
            bh: reference.height,
        });
    }
    if test.encoding != reference.encoding {
        return Err(CompareError::Kind {
            a: test.path.clone(),
            ak: test.encoding.name(),
            b: reference.path.clone(),
            bk: reference.encoding.name(),
        });
    }
    Ok(())
}

/// FLIP's per-pixel error map of `test` against `reference` (same size).
fn flip_map(test: &Image, reference: &Image) -> nv_flip::FlipImageFloat {
    let img = |i: &Image| nv_flip::FlipImageRgb8::with_data(i.width, i.height, &i.srgb8());
    nv_flip::flip(img(reference), img(test), PIXELS_PER_DEGREE)
}

/// Measures `test` against `reference`.
pub fn compare(test: &Image, reference: &Image) -> Result<Comparison, CompareError> {
    check_pair(test, reference)?;
    let mut worst = (0usize, 0.0f32);
    for (k, (a, b)) in test.pixels.iter().zip(&reference.pixels).enumerate() {
        let d = (*a - *b).abs().max_element();
        if d > worst.1 {
            worst = (k, d);
        }
    }
    let (k, max_abs) = worst;
    let mean_flip = if test.pixels.is_empty() {
        0.0
    } else {
        f64::from(nv_flip::FlipPool::from_image(&flip_map(test, reference)).mean())
    };
    Ok(Comparison {
        speckles: speckles(test.width, &test.pixels, &reference.pixels, None),
        rel_mse: rel_mse(&test.pixels, &reference.pixels),
        mean_flip,
        max_abs,
        worst: Worst {
            x: k as u32 % test.width.max(1),
            y: k as u32 / test.width.max(1),
            test: test.pixels.get(k).copied().unwrap_or(Vec3::ZERO),
            reference: reference.pixels.get(k).copied().unwrap_or(Vec3::ZERO),
        },
    })
}

/// Luminance off the reference's by more than this factor, either way,
/// makes a pixel an outlier.
pub const SPECKLE_FACTOR: f32 = 2.0;

/// Reference luminance from which a pixel counts as lit: outliers are
/// counted among lit pixels (a ratio of two near-zero values says nothing).
pub const SPECKLE_LIT: f32 = 1e-2;

/// Outliers among the lit pixels away from edges: how many pixels carry a
/// luminance below 1/[`SPECKLE_FACTOR`] or above [`SPECKLE_FACTOR`] times
/// the reference's.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Speckles {
    pub dark: usize,
    pub bright: usize,
    /// The pixels counted among: lit and away from edges.
    pub lit: usize,
}

impl Speckles {
    /// Share of the lit pixels that are outliers (0 when none is lit).
    pub fn fraction(&self) -> f64 {
        (self.dark + self.bright) as f64 / self.lit.max(1) as f64
    }
}

/// Counts isolated outliers of `test` (row-major, `width` pixels a row)
/// against `reference`.
///
/// Away from edges: `mask` says where (the G-buffer's interior, when the
/// caller has one); without it a pixel counts where the reference's own 3x3
/// neighbourhood is smooth (every neighbour's luminance within
/// [`SPECKLE_FACTOR`] of the pixel's), which leaves out silhouettes, hard
/// shadow edges and the frame's border, where a sub-pixel shift alone puts
/// a pixel 2x off. A speckle is an outlier where the truth is smooth.
pub fn speckles(width: u32, test: &[Vec3], reference: &[Vec3], mask: Option<&[bool]>) -> Speckles {
    let w = width as usize;
    let n = test.len().min(reference.len());
    let h = n.checked_div(w).unwrap_or(0);
    let lum = |c: Vec3| crate::denoise::luminance(c);
    let smooth = |x: usize, y: usize| {
        if x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
            return false;
        }
        let c = lum(reference[y * w + x]);
        (y - 1..=y + 1).all(|yy| {
            (x - 1..=x + 1).all(|xx| {
                let q = lum(reference[yy * w + xx]);
                q * SPECKLE_FACTOR >= c && q <= c * SPECKLE_FACTOR
            })
        })
    };
    let mut out = Speckles::default();
    for k in 0..w * h {
        let r = lum(reference[k]);
        if !(r >= SPECKLE_LIT && r.is_finite()) {
            continue;
        }
        let away = match mask {
            Some(m) => m.get(k).copied().unwrap_or(false),
            None => smooth(k % w, k / w),
        };
        if !away {
            continue;
        }
        out.lit += 1;
        let t = lum(test[k]);
        if t * SPECKLE_FACTOR < r {
            out.dark += 1;
        } else if t > r * SPECKLE_FACTOR {
            out.bright += 1;
        }
    }
    out
}

/// Relative depth step between neighbours taken as a geometric edge.
pub const DEPTH_EDGE: f32 = 0.05;

/// Where a depth image (`render --aov depth`, of `reference`'s size) shows a
/// surface whose 8 neighbours are surfaces within [`DEPTH_EDGE`] of its
/// depth: the pixels away from geometric edges.
pub fn away_from_depth_edges(depth: &Image, reference: &Image) -> Result<Vec<bool>, CompareError> {
    check_pair(depth, reference)?;
    let (w, h) = (depth.width as usize, depth.height as usize);
    let d = |x: usize, y: usize| depth.pixels[y * w + x].x;
    Ok((0..w * h)
        .map(|k| {
            let (x, y) = (k % w, k / w);
            if x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
                return false;
            }
            let c = d(x, y);
            c > 0.0
                && (y - 1..=y + 1).all(|yy| {
                    (x - 1..=x + 1).all(|xx| {
                        let q = d(xx, yy);
                        q > 0.0 && (q - c).abs() <= DEPTH_EDGE * c
                    })
                })
        })
        .collect())
}

/// Writes FLIP's error map of `test` against `reference` as a PNG, in FLIP's
/// magma colours (black: no visible difference; yellow-white: the largest).
pub fn write_heatmap(test: &Image, reference: &Image, path: &Path) -> Result<(), CompareError> {
    check_pair(test, reference)?;
    let err = |source| CompareError::Write {
        path: path.to_path_buf(),
        source,
    };
    let shown = flip_map(test, reference).apply_color_lut(&nv_flip::magma_lut());
    let img = image::RgbImage::from_raw(shown.width(), shown.height(), shown.to_vec())
        .expect("FLIP's map has the images' size");
    img.save_with_format(path, ImageFormat::Png).map_err(err)
}

/// The comparison as `penumbra compare` prints it.
pub fn format(c: &Comparison) -> String {
    let v = |c: Vec3| format!("({:.6}, {:.6}, {:.6})", c.x, c.y, c.z);
    format!(
        "relMSE     {:.6e}\nmean FLIP  {:.6}\nmax |a-b|  {:.6}\nworst      pixel ({}, {}): a = {}, b = {}\n\
         speckles   {:.3} % of {} lit pixels away from edges ({} dark, {} bright; off by over {}x)\n",
        c.rel_mse,
        c.mean_flip,
        c.max_abs,
        c.worst.x,
        c.worst.y,
        v(c.worst.test),
        v(c.worst.reference),
        c.speckles.fraction() * 100.0,
        c.speckles.lit,
        c.speckles.dark,
        c.speckles.bright,
        SPECKLE_FACTOR
    )
}
