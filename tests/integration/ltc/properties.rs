//! Random configurations: U is finite, >= 0, Lambert matches brute force,
//! and the F0 = 1 specular is within the fit's error bound of brute force.
//! Bound (measured by `ltc::accuracy`, loose on purpose): the specular
//! error is at most 10% of the whole lobe's integral `L ∫ f cos`, i.e. the
//! LTC never misplaces more than a tenth of the highlight's energy.

use crate::support::ltc::{lobe_total, point_z, quad_light, reference, rel};
use glam::{Quat, Vec3};
use penumbra::shading::unshadowed_lobes;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, .. ProptestConfig::default() })]

    #[test]
    fn unshadowed_is_finite_nonnegative_and_near_brute_force(
        cx in -3.0f32..3.0, cy in -3.0f32..3.0, cz in -1.0f32..3.0,
        ax in -3.1f32..3.1, ay in -3.1f32..3.1,
        hu in 0.01f32..2.0, hv in 0.01f32..2.0,
        two_sided in any::<bool>(),
        view in 0.0f32..89.0,
        roughness in 0.0f32..=1.0,
    ) {
        let q = Quat::from_euler(glam::EulerRot::XYZ, ax, ay, 0.0);
        let light = quad_light(Vec3::new(cx, cy, cz), q * Vec3::X * hu, q * Vec3::Y * hv, Vec3::ONE, two_sided);
        let sp = point_z(Vec3::ZERO, view, Vec3::ONE, roughness);
        let (d, s) = unshadowed_lobes(&sp, &light);
        prop_assert!(d.is_finite() && s.is_finite());
        prop_assert!(d.min_element() >= 0.0 && s.min_element() >= 0.0);
        let (rd, rs) = reference(&sp, &light, 1e-4).lobes(&sp, &light);
        prop_assert!(rel(d.x, rd.x) <= 1e-3 || (d.x - rd.x).abs() < 1e-6, "diffuse {} vs {}", d.x, rd.x);
        let lobe = lobe_total(roughness, sp.wo);
        prop_assert!((s.x - rs.x).abs() <= 0.1 * lobe, "specular {} vs {} (lobe {lobe})", s.x, rs.x);
    }
}
