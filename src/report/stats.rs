//! Small statistics over repeated measurements.

/// Median of the values (mean of the middle two for even counts); 0 if empty.
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

/// Relative mean squared error against a reference, per DESIGN.md:
/// mean((x - ref)^2 / (ref^2 + 1e-2)) over pixels and channels.
pub fn rel_mse(x: &[glam::Vec3], reference: &[glam::Vec3]) -> f64 {
    assert_eq!(x.len(), reference.len(), "images differ in size");
    let mut sum = 0.0f64;
    for (a, r) in x.iter().zip(reference) {
        for c in 0..3 {
            let (a, r) = (a[c] as f64, r[c] as f64);
            sum += (a - r) * (a - r) / (r * r + 1e-2);
        }
    }
    sum / (3 * x.len().max(1)) as f64
}

/// The glossy receiver where a shadow falls, for the seed's claim on `room`:
/// pixels of `material` away from geometric edges whose resolved roughness is
/// below `max_roughness` at the pixel and its 8 neighbours (polished tiles,
/// not grout or its bevel), and where some of the lights' area is blocked
/// (`probe`, an area-visibility frame, has S_N below U_N).
pub fn shadowed_glossy(
    probe: &crate::render::Frame,
    material: u32,
    max_roughness: f32,
) -> Vec<bool> {
    let (w, h) = (probe.width as usize, probe.height as usize);
    let inside = interior(probe.width, probe.height, &probe.gbuf);
    let glossy = |k: usize| {
        let g = &probe.gbuf[k];
        g.kind == crate::render::PixelKind::Surface
            && g.material == material
            && g.roughness < max_roughness
    };
    (0..w * h)
        .map(|k| {
            // `interior` is false on the border, so the 3x3 never leaves the frame.
            inside[k]
                && (0..9).all(|i| glossy(k + (i % 3) + (i / 3) * w - w - 1))
                && probe.sn[k].element_sum() < 0.98 * probe.un[k].element_sum()
        })
        .collect()
}

/// `interior` of the G-buffer `world` gives through `camera` at
/// `width` x `height` (one unshadowed frame traced in `pool`).
pub fn interior_of_view(
    world: &crate::render::World,
    camera: &crate::scene::Camera,
    (width, height): (u32, u32),
    pool: &rayon::ThreadPool,
) -> Vec<bool> {
    use crate::render::{Frame, Mode, RenderSettings};
    let mut f = Frame::new(width, height);
    let s = RenderSettings {
        mode: Mode::Unshadowed,
        ..RenderSettings::default()
    };
    pool.install(|| f.render(world, camera, &s));
    interior(width, height, &f.gbuf)
}

/// Pixels away from geometric edges: the pixel and its 8 neighbours see the
/// same kind of thing with the same material (in a G-buffer traced at pixel
/// centres). The reference's box filter blends across edges; comparing
/// estimators on these pixels leaves the pixel filter out of the figure.
pub fn interior(width: u32, height: u32, gbuf: &[crate::render::GSample]) -> Vec<bool> {
    let (w, h) = (width as i64, height as i64);
    let key = |x: i64, y: i64| {
        let g = &gbuf[(y * w + x) as usize];
        (g.kind, g.material)
    };
    (0..w * h)
        .map(|k| {
            let (x, y) = (k % w, k / w);
            if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                return false;
            }
            let centre = key(x, y);
            (-1..=1).all(|dy| (-1..=1).all(|dx| key(x + dx, y + dy) == centre))
        })
        .collect()
}

/// `rel_mse` over the pixels where `mask` holds.
pub fn rel_mse_masked(x: &[glam::Vec3], reference: &[glam::Vec3], mask: &[bool]) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for ((a, r), _) in x.iter().zip(reference).zip(mask).filter(|(_, m)| **m) {
        for c in 0..3 {
            let (a, r) = (a[c] as f64, r[c] as f64);
            sum += (a - r) * (a - r) / (r * r + 1e-2);
        }
        n += 3;
    }
    sum / n.max(1) as f64
}

/// Median and spread of repeated measurements: extremes and quartiles.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Spread {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    /// First and third quartiles (linear interpolation between order statistics).
    pub q1: f64,
    pub q3: f64,
}

impl Spread {
    /// The spread of `values`; all zero if there are none.
    pub fn of(values: &[f64]) -> Spread {
        if values.is_empty() {
            return Spread::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        Spread {
            median: median(&v),
            min: v[0],
            max: v[v.len() - 1],
            q1: quantile_sorted(&v, 0.25),
            q3: quantile_sorted(&v, 0.75),
        }
    }

    /// Every figure multiplied by `k` (e.g. seconds to milliseconds).
    pub fn scaled(self, k: f64) -> Spread {
        Spread {
            median: self.median * k,
            min: self.min * k,
            max: self.max * k,
            q1: self.q1 * k,
            q3: self.q3 * k,
        }
    }
}

/// The `q`-quantile of sorted, non-empty values.
fn quantile_sorted(v: &[f64], q: f64) -> f64 {
    let pos = q * (v.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}

/// `y` at `x` on the polyline through `points` (x ascending after sorting),
/// interpolated linearly in log x and log y; `None` outside the points' x
/// range or when a value is not positive.
pub fn interpolate_log_log(points: &[(f64, f64)], x: f64) -> Option<f64> {
    let mut p: Vec<(f64, f64)> = points.to_vec();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    if x <= 0.0 || p.iter().any(|&(a, b)| a <= 0.0 || b <= 0.0) {
        return None;
    }
    p.windows(2).find(|w| w[0].0 <= x && x <= w[1].0).map(|w| {
        let (x0, y0, x1, y1) = (w[0].0.ln(), w[0].1.ln(), w[1].0.ln(), w[1].1.ln());
        if x1 == x0 {
            return y0.exp();
        }
        (y0 + (y1 - y0) * (x.ln() - x0) / (x1 - x0)).exp()
    })
}

/// The 2x2 pixels around `pixel` (continuous coordinates, pixel centres at
/// +0.5) with their bilinear weights, as (index, weight) into a row-major
/// `width` x `height` image; `None` unless all four are on screen. Measurements
/// that follow a surface point across frames use it (flicker, reprojection).
pub fn bilinear_taps(pixel: glam::Vec2, width: usize, height: usize) -> Option<[(usize, f32); 4]> {
    let q = pixel - 0.5;
    let (x0, y0) = (q.x.floor(), q.y.floor());
    if x0 < 0.0 || y0 < 0.0 || x0 + 1.0 >= width as f32 || y0 + 1.0 >= height as f32 {
        return None;
    }
    let (fx, fy) = (q.x - x0, q.y - y0);
    let j = y0 as usize * width + x0 as usize;
    Some([
        (j, (1.0 - fx) * (1.0 - fy)),
        (j + 1, fx * (1.0 - fy)),
        (j + width, (1.0 - fx) * fy),
        (j + width + 1, fx * fy),
    ])
}
