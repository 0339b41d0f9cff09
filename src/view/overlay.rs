//! What the window says about itself: the overlay drawn into the frame, the
//! title bar, and the summary printed when the window closes.

use super::font::{ADVANCE_Y, Canvas, text_width};
use super::input::HELP;
use crate::render::{Mode, VisibilityRate};

/// The figures of one shown frame, in seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameTiming {
    /// Band pass and composite: the frame's wall time less the denoiser.
    pub render: f64,
    pub denoise: f64,
    /// The passes at the window's size: upscale (under a target frame
    /// rate), display transform, overlay and handing the pixels to the
    /// window.
    pub output: f64,
    /// Of `output`: the upscale with the display transform fused into it
    /// (0 at the window's size), the rest being overlay and copy.
    pub upscale: f64,
    /// The whole loop iteration, input to input.
    pub total: f64,
    /// Camera and shadow rays traced.
    pub rays: u64,
    /// Render size over window size (1: the window's size).
    pub scale: f32,
    /// The window's pixels.
    pub output_pixels: u64,
}

impl FrameTiming {
    pub fn mrays_per_s(&self) -> f64 {
        if self.render > 0.0 {
            self.rays as f64 / self.render * 1e-6
        } else {
            0.0
        }
    }
}

/// Everything the overlay and the title show.
#[derive(Debug, Clone, PartialEq)]
pub struct Readout {
    pub mode: Mode,
    /// `None` when the mode does not use the denoiser.
    pub denoise: Option<bool>,
    /// Jitter + temporal resolve; `None` for `reference` (its own jitter).
    pub taa: Option<bool>,
    /// Which pixels draw visibility samples; `None` where nothing is
    /// denoised (every pixel samples).
    pub visibility: Option<VisibilityRate>,
    /// Render size over window size under a target frame rate.
    pub scale: Option<f32>,
    /// Samples per pixel per frame.
    pub spp: u32,
    /// `reference`: samples per pixel accumulated so far.
    pub accumulated: Option<u32>,
    pub width: u32,
    pub height: u32,
    /// Smoothed over recent frames.
    pub timing: FrameTiming,
    pub speed: f32,
    /// A passing message (e.g. where a screenshot went).
    pub status: Option<String>,
    pub help: bool,
}

impl Readout {
    fn denoise_word(&self) -> &'static str {
        match self.denoise {
            Some(true) => "DENOISE ON",
            Some(false) => "DENOISE OFF",
            None => "NO DENOISER",
        }
    }

    fn taa_word(&self) -> &'static str {
        match self.taa {
            Some(true) => "  TAA ON",
            Some(false) => "  TAA OFF",
            None => "",
        }
    }

    fn visibility_words(&self) -> String {
        match self.visibility {
            // Short words: the first line must fit a 320-pixel window.
            Some(VisibilityRate::Quarter) => "  VIS 1/4".to_string(),
            Some(r) => format!("  VIS {}", r.name().to_uppercase()),
            None => String::new(),
        }
    }

    fn spp_words(&self) -> String {
        match self.accumulated {
            Some(total) => format!("{total} SPP (+{}/FRAME)", self.spp),
            None => format!("{} SPP", self.spp),
        }
    }

    fn fps(&self) -> f64 {
        if self.timing.total > 0.0 {
            1.0 / self.timing.total
        } else {
            0.0
        }
    }

    /// The overlay's lines, top to bottom.
    pub fn lines(&self) -> Vec<String> {
        let t = &self.timing;
        let mut lines = vec![
            format!(
                "{}  {}{}{}  {}  {}X{}{}",
                self.mode.name().to_uppercase(),
                self.denoise_word(),
                self.taa_word(),
                self.visibility_words(),
                self.spp_words(),
                self.width,
                self.height,
                self.scale
                    .map_or(String::new(), |s| format!(" ({:.0}%)", s * 100.0))
            ),
            format!(
                "MS RENDER {:.1} DENOISE {:.1} OUTPUT {:.1}",
                t.render * 1e3,
                t.denoise * 1e3,
                t.output * 1e3
            ),
            format!(
                "{} FPS  {:.1} MRAYS/S  SPEED {:.2}  H HELP",
                fps_digits(self.fps()),
                t.mrays_per_s(),
                self.speed
            ),
        ];
        if let Some(s) = &self.status {
            lines.push(s.clone());
        }
        if self.help {
            lines.push(String::new());
            lines.extend(HELP.iter().map(|s| s.to_string()));
        }
        lines
    }

    /// The title bar: the essentials of the first three lines.
    pub fn title(&self) -> String {
        format!(
            "penumbra - {} - {} - {} - {}x{} - {:.1} ms render - {} fps",
            self.mode,
            self.denoise_word().to_lowercase(),
            self.spp_words().to_lowercase(),
            self.width,
            self.height,
            self.timing.render * 1e3,
            fps_digits(self.fps())
        )
    }
}

/// Frames per second, with two decimals below 10 so that a slow frame rate
/// still reads as a number.
fn fps_digits(fps: f64) -> String {
    if fps < 10.0 {
        format!("{fps:.2}")
    } else {
        format!("{fps:.1}")
    }
}

/// Font scale for a frame: one cell per pixel up to 540 rows, then two.
pub fn scale_for(height: usize) -> usize {
    if height >= 540 { 2 } else { 1 }
}

const MARGIN: usize = 4;
const PAD: usize = 3;
const TEXT: u32 = 0x00f0_f0d8;

/// Draws `lines` in the top-left corner over a darkened box. Returns the
/// box as (x, y, width, height), clipped to the frame.
pub fn draw(
    pixels: &mut [u32],
    width: usize,
    height: usize,
    lines: &[String],
) -> (usize, usize, usize, usize) {
    let scale = scale_for(height);
    let m = MARGIN * scale;
    let p = PAD * scale;
    let text_w = lines
        .iter()
        .map(|l| text_width(l, scale))
        .max()
        .unwrap_or(0);
    let text_h = (lines.len() * ADVANCE_Y).saturating_sub(ADVANCE_Y - super::font::GLYPH_H) * scale;
    let (bw, bh) = (text_w + 2 * p, text_h + 2 * p);
    let mut canvas = Canvas {
        pixels,
        width,
        height,
    };
    canvas.shade(m, m, bw, bh);
    for (i, line) in lines.iter().enumerate() {
        canvas.text(m + p, m + p + i * ADVANCE_Y * scale, scale, TEXT, line);
    }
    let clip = |origin: usize, len: usize, max: usize| max.saturating_sub(origin).min(len);
    (m, m, clip(m, bw, width), clip(m, bh, height))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn readout() -> Readout {
        Readout {
            mode: Mode::Ratio,
            denoise: Some(true),
            taa: Some(true),
            visibility: Some(VisibilityRate::Quarter),
            scale: None,
            spp: 2,
            accumulated: None,
            width: 320,
            height: 180,
            timing: FrameTiming {
                render: 0.025,
                denoise: 0.004,
                output: 0.001,
                upscale: 0.0,
                total: 0.04,
                rays: 2_000_000,
                scale: 1.0,
                output_pixels: 320 * 180,
            },
            speed: 2.5,
            status: None,
            help: false,
        }
    }

    #[test]
    fn the_overlay_names_mode_denoiser_taa_spp_size_times_fps_and_rays() {
        let lines = readout().lines();
        assert_eq!(
            lines[0],
            "RATIO  DENOISE ON  TAA ON  VIS 1/4  2 SPP  320X180"
        );
        assert_eq!(lines[1], "MS RENDER 25.0 DENOISE 4.0 OUTPUT 1.0");
        assert_eq!(lines[2], "25.0 FPS  80.0 MRAYS/S  SPEED 2.50  H HELP");
        let title = readout().title();
        assert!(
            title.contains("ratio") && title.contains("25.0 fps"),
            "{title}"
        );
    }

    #[test]
    fn reference_shows_accumulated_samples_and_no_denoiser() {
        let r = Readout {
            mode: Mode::Reference,
            denoise: None,
            taa: None,
            visibility: None,
            accumulated: Some(64),
            ..readout()
        };
        assert_eq!(
            r.lines()[0],
            "REFERENCE  NO DENOISER  64 SPP (+2/FRAME)  320X180"
        );
    }

    #[test]
    fn help_adds_the_key_lines() {
        let r = Readout {
            help: true,
            ..readout()
        };
        assert_eq!(r.lines().len(), 3 + 1 + HELP.len());
    }

    #[test]
    fn every_line_fits_a_320_pixel_window_at_scale_one() {
        let r = Readout {
            help: true,
            ..readout()
        };
        for line in r.lines() {
            assert!(
                MARGIN + 2 * PAD + text_width(&line, 1) <= 320,
                "{line:?} is too wide"
            );
        }
    }

    #[test]
    fn drawing_touches_only_the_box_and_writes_text_in_it() {
        let (w, h) = (320, 180);
        let mut pixels = vec![0x0080_8080u32; w * h];
        let (x, y, bw, bh) = draw(&mut pixels, w, h, &readout().lines());
        let mut text = 0;
        for (k, &p) in pixels.iter().enumerate() {
            let (px, py) = (k % w, k / w);
            let inside = (x..x + bw).contains(&px) && (y..y + bh).contains(&py);
            match p {
                0x0080_8080 => assert!(!inside, "({px},{py}) inside the box was not shaded"),
                TEXT => {
                    assert!(inside);
                    text += 1
                }
                0x0020_2020 => assert!(inside),
                other => panic!("unexpected pixel {other:#x}"),
            }
        }
        assert!(text > 300, "{text} text pixels");
        assert!(bh < h / 3, "three lines stay in the top third");
    }
}
