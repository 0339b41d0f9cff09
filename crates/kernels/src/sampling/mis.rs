//! Multiple importance sampling weights (Veach 1997) for one sample from each
//! of two strategies. Both guard the cases a renderer actually produces: a
//! zero pdf on both sides (weight 0, never NaN) and an infinite pdf (delta-like
//! limit: the infinite side takes the whole weight).

/// Balance heuristic weight of strategy `a`: `pa / (pa + pb)`.
pub fn balance_heuristic(pa: f32, pb: f32) -> f32 {
    if pa.is_infinite() {
        return 1.0;
    }
    let s = pa + pb;
    if s > 0.0 && s.is_finite() {
        pa / s
    } else {
        0.0
    }
}

/// Power heuristic (beta = 2) weight of strategy `a`: `pa^2 / (pa^2 + pb^2)`.
/// Written as `1 / (1 + (pb/pa)^2)` so large pdfs do not overflow the squares.
pub fn power_heuristic(pa: f32, pb: f32) -> f32 {
    if pa.is_infinite() {
        return 1.0;
    }
    if pa <= 0.0 || pb.is_infinite() {
        return 0.0;
    }
    let r = pb / pa;
    1.0 / (1.0 + r * r)
}
