//! The speed-against-error chart: relMSE against ms per frame, log-log, one
//! series per mode (denoised and not), points labelled by spp; one panel
//! per scene.
//!
//! plotters draws text through ab_glyph with a TrueType font read at run
//! time (`PENUMBRA_FONT`, else DejaVu Sans from Debian's fonts-dejavu-core),
//! so the build needs no font and no fontconfig.

use super::results::{BenchReport, SceneReport};
use anyhow::{Context, Result, anyhow, bail};
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::{Path, PathBuf};

const FONT_PATHS: [&str; 2] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
];
const PANEL_W: u32 = 900;
const PANEL_H: u32 = 600;

/// Finds and registers the chart's font; call before a long run so a
/// missing font is reported at once.
pub fn load_font() -> Result<()> {
    let candidates: Vec<PathBuf> = match std::env::var_os("PENUMBRA_FONT") {
        Some(p) => vec![PathBuf::from(p)],
        None => FONT_PATHS.iter().map(PathBuf::from).collect(),
    };
    let Some(path) = candidates.iter().find(|p| p.is_file()) else {
        bail!(
            "--plot needs a TrueType font and none was found at {}: install fonts-dejavu-core \
             (`make deps` does) or set PENUMBRA_FONT to a .ttf file",
            candidates
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    };
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    // plotters keeps fonts for the life of the program.
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
        .map_err(|_| anyhow!("{}: not a TrueType font plotters can read", path.display()))
}

/// Draws the chart of every scene in `report` to a PNG at `path`.
pub fn plot(report: &BenchReport, path: &Path) -> Result<()> {
    load_font()?;
    let n = report.scenes.len().max(1) as u32;
    let (w, h) = (PANEL_W * n, PANEL_H);
    let mut pixels = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let panels = root.split_evenly((1, n as usize));
        for (panel, scene) in panels.iter().zip(&report.scenes) {
            draw_scene(panel, scene, report).map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    let img = image::RgbImage::from_raw(w, h, pixels).expect("buffer matches size");
    img.save(path)
        .with_context(|| format!("writing {}", path.display()))
}

fn draw_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing the chart: {e}")
}

/// Series: (label, colour), in legend order.
const SERIES: [(&str, RGBColor); 8] = [
    ("ratio+dn", RGBColor(200, 30, 30)),
    ("ratio+dn 1/4", RGBColor(230, 120, 20)),
    ("ratio+dn 50% res", RGBColor(150, 40, 160)),
    ("ratio", RGBColor(240, 140, 140)),
    ("stochastic+dn", RGBColor(30, 70, 200)),
    ("stochastic", RGBColor(140, 170, 240)),
    ("soft-shadow+dn", RGBColor(30, 150, 60)),
    ("unshadowed", RGBColor(90, 90, 90)),
];

fn draw_scene<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    s: &SceneReport,
    report: &BenchReport,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let pts: Vec<(f64, f64)> = s
        .configs
        .iter()
        .filter(|c| c.rel_mse > 0.0 && c.frame_ms.median > 0.0)
        .map(|c| (c.frame_ms.median, c.rel_mse))
        .collect();
    let bounds = |f: fn(&(f64, f64)) -> f64| {
        let lo = pts.iter().map(f).fold(f64::INFINITY, f64::min);
        let hi = pts.iter().map(f).fold(0.0, f64::max);
        if lo.is_finite() && hi > 0.0 {
            (lo / 1.5, hi * 1.5)
        } else {
            (1e-3, 1.0)
        }
    };
    let (x0, x1) = bounds(|p| p.0);
    let (y0, y1) = bounds(|p| p.1);
    let caption = format!(
        "{}: relMSE vs ms per frame ({}x{}, {} threads)",
        s.scene, report.settings.width, report.settings.height, report.settings.threads
    );
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("ms per frame (median)")
        .y_desc("relMSE against the reference")
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .x_label_formatter(&|x| format!("{x:.0}"))
        .x_labels(6)
        .y_labels(6)
        .label_style(("sans-serif", 14))
        .draw()?;
    for (name, colour) in SERIES {
        let mut series: Vec<(f64, f64, u32)> = s
            .configs
            .iter()
            .filter(|c| c.label == name && c.rel_mse > 0.0)
            .map(|c| (c.frame_ms.median, c.rel_mse, c.spp))
            .collect();
        if series.is_empty() {
            continue;
        }
        // Joined in sample order: timing noise must not zigzag the curve.
        series.sort_by_key(|p| p.2);
        let style = ShapeStyle::from(colour).stroke_width(2);
        // One segment each: joins of a line that turns back (timing noise)
        // would spike.
        chart.draw_series(
            series
                .windows(2)
                .map(|w| PathElement::new(vec![(w[0].0, w[0].1), (w[1].0, w[1].1)], style)),
        )?;
        chart
            .draw_series(series.iter().map(|&(x, y, spp)| {
                let text = if spp > 0 {
                    format!("{spp}")
                } else {
                    String::new()
                };
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(text, (6, -16), ("sans-serif", 14).into_font())
            }))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    Ok(())
}
