//! A small Nelder-Mead simplex minimiser (derivative-free), used by the LTC
//! fit: the fit error is a sampled integral, noisy in its derivatives but
//! smooth enough for a simplex search. Deterministic: no randomness inside.

/// Minimises `f` from `start`, with an initial simplex of `start` plus
/// `step[i]` along each axis. Stops after `max_evals` evaluations or when the
/// simplex's function values agree to `ftol` (relative). Returns the best
/// point and its value.
pub fn minimize<const N: usize>(
    mut f: impl FnMut(&[f64; N]) -> f64,
    start: [f64; N],
    step: [f64; N],
    ftol: f64,
    max_evals: usize,
) -> ([f64; N], f64) {
    // Standard coefficients: reflection 1, expansion 2, contraction 1/2, shrink 1/2.
    let mut pts = vec![start; N + 1];
    for i in 0..N {
        pts[i + 1][i] += step[i];
    }
    let mut vals: Vec<f64> = pts.iter().map(&mut f).collect();
    let mut evals = N + 1;

    let combine = |a: &[f64; N], b: &[f64; N], t: f64| -> [f64; N] {
        // a + t (b - a)
        let mut r = [0.0; N];
        for i in 0..N {
            r[i] = a[i] + t * (b[i] - a[i]);
        }
        r
    };

    while evals < max_evals {
        // Order: best first, worst last.
        let mut order: Vec<usize> = (0..=N).collect();
        order.sort_by(|&a, &b| vals[a].total_cmp(&vals[b]));
        pts = order.iter().map(|&i| pts[i]).collect();
        vals = order.iter().map(|&i| vals[i]).collect();

        let (best, worst) = (vals[0], vals[N]);
        if (worst - best).abs() <= ftol * (best.abs() + 1e-300) {
            break;
        }

        let mut centroid = [0.0; N];
        for p in &pts[..N] {
            for i in 0..N {
                centroid[i] += p[i] / N as f64;
            }
        }

        let reflected = combine(&centroid, &pts[N], -1.0);
        let fr = f(&reflected);
        evals += 1;
        if fr < vals[0] {
            let expanded = combine(&centroid, &pts[N], -2.0);
            let fe = f(&expanded);
            evals += 1;
            if fe < fr {
                pts[N] = expanded;
                vals[N] = fe;
            } else {
                pts[N] = reflected;
                vals[N] = fr;
            }
        } else if fr < vals[N - 1] {
            pts[N] = reflected;
            vals[N] = fr;
        } else {
            // Contract toward the better of the worst point and its reflection.
            let (toward, fbase) = if fr < vals[N] {
                (reflected, fr)
            } else {
                (pts[N], vals[N])
            };
            let contracted = combine(&centroid, &toward, 0.5);
            let fc = f(&contracted);
            evals += 1;
            if fc < fbase {
                pts[N] = contracted;
                vals[N] = fc;
            } else {
                for k in 1..=N {
                    pts[k] = combine(&pts[0], &pts[k], 0.5);
                    vals[k] = f(&pts[k]);
                }
                evals += N;
            }
        }
    }
    let mut bi = 0;
    for i in 1..=N {
        if vals[i] < vals[bi] {
            bi = i;
        }
    }
    (pts[bi], vals[bi])
}

#[cfg(test)]
mod tests {
    #[test]
    fn finds_the_rosenbrock_minimum() {
        let (x, v) = super::minimize(
            |p: &[f64; 2]| (1.0 - p[0]).powi(2) + 100.0 * (p[1] - p[0] * p[0]).powi(2),
            [-1.2, 1.0],
            [0.1, 0.1],
            1e-14,
            5000,
        );
        assert!(v < 1e-8, "{v} at {x:?}");
        assert!((x[0] - 1.0).abs() < 1e-3 && (x[1] - 1.0).abs() < 1e-3);
    }
}
