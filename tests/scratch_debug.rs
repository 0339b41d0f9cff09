use glam::{DVec3, Vec3};
use penumbra::shading::{brdf, ltc};
use std::f64::consts::PI;

#[test]
fn debug_cell() {
    let t = ltc::table();
    for &(r, th) in &[
        (0.5f32, 0.0f32),
        (0.5, 45.0),
        (0.5, 89.0),
        (1.0, 0.0),
        (0.2, 30.0),
    ] {
        let c = th.to_radians().cos();
        let cell = t.lookup(r, c);
        let mi = cell.inv_matrix();
        let det = mi.determinant().abs();
        let a = brdf::alpha_from_roughness(r);
        let v = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
        // grid over hemisphere in (cos, phi)
        let n = 800;
        let (mut l1, mut tot_b, mut tot_l, mut tot_l_all) = (0.0, 0.0, 0.0, 0.0);
        for j in 0..n {
            for i in 0..2 * n {
                let z = (j as f64 + 0.5) / n as f64;
                let phi = (i as f64 + 0.5) / (2 * n) as f64 * 2.0 * PI;
                let s = (1.0 - z * z).sqrt();
                let w = DVec3::new(s * phi.cos(), s * phi.sin(), z);
                let dw = 2.0 * PI / (2 * n * n) as f64;
                let b = (brdf::spec_f1_local(a, w.as_vec3(), v) as f64) * z;
                let wl = mi * w;
                let len = wl.length();
                let d = if wl.z > 0.0 {
                    wl.z / len / PI * det / len.powi(3)
                } else {
                    0.0
                };
                let l = cell.mag as f64 * d / cell.hmass as f64;
                l1 += (b - l).abs() * dw;
                tot_b += b * dw;
                tot_l += l * dw;
                tot_l_all += d * dw;
            }
        }
        println!(
            "r {r} th {th}: cell {:?}\n   brute mag {tot_b:.5} ltc-mass-upper {tot_l:.5} rawmass_upper {tot_l_all:.5} L1rel {:.4}",
            cell,
            l1 / tot_b
        );
    }
}
