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
