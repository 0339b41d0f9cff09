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
