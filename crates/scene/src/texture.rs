//! Image textures: loading (PNG or EXR, detected from the file's contents)
//! and bilinear sampling.
//!
//! Conventions:
//! - `texels` are stored row by row with row 0 the TOP row of the image, as
//!   image files store them.
//! - Texture coordinates follow OpenGL: (s, t) = (0, 0) is the BOTTOM-left
//!   corner of the image and t grows upwards, so t = 1 is the top row. This
//!   matches OBJ `vt` coordinates and the quad convention (t along v).
//! - Addressing wraps (repeat) in both directions; filtering is bilinear
//!   between texel centres.

use glam::{Vec2, Vec4};
use std::path::Path;

/// An image in linear floating point, RGBA, row 0 at the top.
#[derive(Debug, Clone)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
}

/// How a file's values are turned into linear floats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// 8/16-bit images are sRGB-encoded colour (decoded to linear). Float
    /// images (EXR) are taken as already linear.
    Srgb,
    /// Values are used as stored, scaled to [0, 1] (roughness, normal maps).
    Linear,
}

/// Largest accepted image side; keeps a hostile header from asking for an
/// absurd allocation.
const MAX_SIDE: u32 = 16384;

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// `i` modulo `n` (repeat addressing). Bilinear taps are at most one texel
/// outside the image, so the common case is a compare, not a 64-bit division.
#[inline(always)]
fn wrap(i: i64, n: i64) -> i64 {
    if (0..n).contains(&i) {
        i
    } else if i == -1 {
        n - 1
    } else if i == n {
        0
    } else {
        i.rem_euclid(n)
    }
}

/// `x.floor()` without the libm call it compiles to on baseline x86-64
/// (no SSE4.1 `roundss`), exact: below 2^22 adding and removing 1.5 * 2^23
/// rounds to an integer (no float-to-integer conversion), below 2^31
/// truncation to i32 is exact; the rest (and NaN) takes the library's floor.
#[inline(always)]
fn floor(x: f32) -> f32 {
    const ROUND: f32 = 12_582_912.0;
    if x.abs() < 4_194_304.0 {
        let t = (x + ROUND) - ROUND;
        if t > x { t - 1.0 } else { t }
    } else if x.abs() < 2_147_483_648.0 {
        let t = x as i32 as f32;
        if t > x { t - 1.0 } else { t }
    } else {
        x.floor()
    }
}

/// Where a bilinear sample at one uv reads: the four texel indices and the
/// blend weights. It depends on the texture's size only, so maps of one
/// size share it (`Texture::footprint`, then `sample` per map).
#[derive(Debug, Clone, Copy)]
pub struct TexelFootprint {
    /// `None`: an empty texture or a non-finite uv (reads as zero).
    texels: Option<[usize; 4]>,
    fx: f32,
    fy: f32,
}

impl TexelFootprint {
    /// The four channels of `tex` (a texture of the size this footprint was
    /// made for) blended at once.
    // Always inlined: a per-pixel call from the renderer's per-ISA kernels.
    #[inline(always)]
    pub fn sample(&self, tex: &Texture) -> [f32; 4] {
        let Some([ia, ib, ic, id]) = self.texels else {
            return [0.0; 4];
        };
        let texel = |i: usize| Vec4::from_array(tex.texels.get(i).copied().unwrap_or([0.0; 4]));
        let (a, b) = (texel(ia), texel(ib));
        let (c, d) = (texel(ic), texel(id));
        let top = a + (b - a) * self.fx;
        let bottom = c + (d - c) * self.fx;
        (top + (bottom - top) * self.fy).to_array()
    }
}

impl Texture {
    /// Loads an image; the error is a sentence without the path (the caller
    /// adds it).
    pub fn load(path: &Path, encoding: Encoding) -> Result<Texture, String> {
        let reader = image::ImageReader::open(path)
            .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        Texture::decode(reader, path, encoding)
    }

    /// Decodes an image held in memory (the built-in scene's files); `path`
    /// names it in messages.
    pub fn from_bytes(bytes: &[u8], path: &Path, encoding: Encoding) -> Result<Texture, String> {
        Texture::decode(
            image::ImageReader::new(std::io::Cursor::new(bytes)),
            path,
            encoding,
        )
    }

    fn decode<R: std::io::BufRead + std::io::Seek>(
        reader: image::ImageReader<R>,
        path: &Path,
        encoding: Encoding,
    ) -> Result<Texture, String> {
        let reader = reader
            .with_guessed_format()
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        if reader.format().is_none() {
            return Err(format!(
                "{} is not a supported image (PNG or EXR)",
                path.display()
            ));
        }
        let decoder = reader
            .into_decoder()
            .map_err(|e| format!("cannot decode {}: {e}", path.display()))?;
        // The size from the header is checked before any pixel is decoded, so
        // a hostile header is refused by name instead of as a failed allocation.
        let (width, height) = image::ImageDecoder::dimensions(&decoder);
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(format!(
                "{} is {width}x{height}; each side must be in 1..={MAX_SIDE}",
                path.display()
            ));
        }
        let img = image::DynamicImage::from_decoder(decoder).map_err(|e| match e {
            image::ImageError::Limits(_) => format!(
                "{} ({width}x{height}) is too large to decode within the image reader's memory limit",
                path.display()
            ),
            e => format!("cannot decode {}: {e}", path.display()),
        })?;
        let is_float = matches!(
            img.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        );
        let rgba = img.into_rgba32f();
        let decode = encoding == Encoding::Srgb && !is_float;
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for (i, px) in rgba.pixels().enumerate() {
            let mut t = px.0;
            if decode {
                for c in &mut t[..3] {
                    *c = srgb_to_linear(*c);
                }
            }
            if let Some(c) = t[..3].iter().find(|c| !(0.0..=1.0).contains(*c)) {
                return Err(format!(
                    "{}: texel ({}, {}) has value {c}, outside [0, 1]",
                    path.display(),
                    i % width as usize,
                    i / width as usize
                ));
            }
            texels.push(t);
        }
        Ok(Texture {
            width,
            height,
            texels,
        })
    }

    /// Bilinear sample at (s, t) with repeat addressing; (0, 0) is the
    /// bottom-left corner of the image (see the module notes). Returns zeros
    /// for an empty texture or non-finite coordinates.
    pub fn sample(&self, uv: Vec2) -> [f32; 4] {
        self.footprint(uv).sample(self)
    }

    /// Where `sample` reads at `uv`.
    #[inline(always)]
    pub fn footprint(&self, uv: Vec2) -> TexelFootprint {
        let (w, h) = (self.width as i64, self.height as i64);
        if w == 0 || h == 0 || !uv.is_finite() {
            return TexelFootprint {
                texels: None,
                fx: 0.0,
                fy: 0.0,
            };
        }
        // Continuous texel coordinates with texel centres at integers + 0.5;
        // y counts rows from the top, hence 1 - t. fract keeps the numbers
        // small so huge repeat counts do not lose precision.
        let s = uv.x - floor(uv.x);
        let t = uv.y - floor(uv.y);
        let x = s * self.width as f32 - 0.5;
        let y = (1.0 - t) * self.height as f32 - 0.5;
        let (x0, y0) = (floor(x), floor(y));
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (xa, xb) = (wrap(x0, w), wrap(x0 + 1, w));
        let (ya, yb) = (wrap(y0, h) * w, wrap(y0 + 1, h) * w);
        TexelFootprint {
            texels: Some([ya + xa, ya + xb, yb + xa, yb + xb].map(|i| i as usize)),
            fx,
            fy,
        }
    }
}
