use crate::support::sampling::*;
use glam::{Vec2, Vec3};
use penumbra::sampling::{intersect_light, light_pdf, sample_light};
use penumbra::scene::Light;
use proptest::prelude::*;

fn vec3(r: f32) -> impl Strategy<Value = Vec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn unit() -> impl Strategy<Value = Vec3> {
    vec3(1.0).prop_filter_map("non-zero", |v| v.try_normalize())
}

/// Rectangles, general parallelograms and convex polygons (points on an
/// ellipse at sorted angles are convex), anywhere, any size, either sidedness.
fn light() -> impl Strategy<Value = Light> {
    let center = (vec3(1.0), -4.0f32..4.0).prop_map(|(c, e)| c * 10f32.powf(e));
    let size = (-4.0f32..3.0).prop_map(|e| 10f32.powf(e));
    (
        center,
        size,
        unit(),
        unit(),
        0.1f32..1.0,
        any::<bool>(),
        0u8..3,
        prop::collection::vec(0.0f32..1.0, 3..=8),
    )
        .prop_filter_map(
            "non-degenerate frame",
            |(c, s, a, d, aspect, two, kind, angles)| {
                let b = a.cross(d).try_normalize()?;
                let a2 = b.cross(a);
                match kind {
                    0 => Some(quad_light(c, a * s, a2 * s * aspect, two)),
                    1 => Some(quad_light(
                        c,
                        a * s,
                        (a2 + d * 0.5).normalize() * s * aspect,
                        two,
                    )),
                    _ => {
                        let mut t: Vec<f32> =
                            angles.iter().map(|x| x * std::f32::consts::TAU).collect();
                        t.sort_by(f32::total_cmp);
                        t.dedup_by(|x, y| (*x - *y).abs() < 0.05);
                        if t.len() < 3 {
                            return None;
                        }
                        let v = t
                            .iter()
                            .map(|t| c + s * (t.cos() * a + aspect * t.sin() * a2))
                            .collect();
                        let l = polygon_light(v, two);
                        (l.area > 0.0 && l.normal.is_finite()).then_some(l)
                    }
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn sample_light_is_finite_with_positive_pdf_and_unit_direction(
        l in light(), p in (vec3(1.0), -3.0f32..4.0).prop_map(|(v, e)| v * 10f32.powf(e)),
        u in (0.0f32..1.0, 0.0f32..1.0),
    ) {
        if let Some(s) = sample_light(&l, p, Vec2::new(u.0, u.1)) {
            prop_assert!(s.pdf.is_finite() && s.pdf > 0.0, "{:?}", s);
            prop_assert!(s.dist.is_finite() && s.dist > 0.0, "{:?}", s);
            prop_assert!((s.wi.length() - 1.0).abs() < 1e-4, "{:?}", s);
            // Away from grazing the sample must be on the light and agree with light_pdf.
            let side = (p - l.vertices[0]).dot(l.normal).abs();
            if side > 1e-2 * s.dist && s.dist < 1e3 * l.area.sqrt() {
                prop_assert!(intersect_light(&l, p, s.wi).is_some(), "{:?}", s);
                let (pdf, _) = light_pdf(&l, p, s.wi).unwrap();
                prop_assert!((pdf / s.pdf - 1.0).abs() < 1e-2, "{} vs {:?}", pdf, s);
            }
        }
    }
}
