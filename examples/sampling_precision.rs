//! Measures where the f32 spherical samplers lose precision, to choose
//! `SOLID_ANGLE_AREA_FALLBACK`. For random rectangles and triangles scaled to a
//! target solid angle it reports the worst error of the samplers' marginal CDF
//! in u.x: the f64 solid angle of the sub-light swept up to the sampled column
//! (rectangle) or corner c' (triangle), divided by the total, minus u.x.
//!
//! `cargo run --release --example sampling_precision`

use glam::{DVec3, Vec2, Vec3};
use penumbra::sampling::sequence::Pcg32;
use penumbra::sampling::spherical_rect::SphericalRect;
use penumbra::sampling::spherical_tri;

fn vos(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let t = a.dot((b - a).cross(c - a)).abs();
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    2.0 * t.atan2(la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la)
}

fn random_unit(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.next_f32() - 1.0;
    let phi = std::f32::consts::TAU * rng.next_f32();
    let r = (1.0 - z * z).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn main() {
    let mut rng = Pcg32::new(7, 1);
    println!("target_sr   rect_cdf_err  rect_S_relerr  tri_cdf_err");
    for e in (-14..=0).map(|k| k as f32 * 0.5) {
        let target = 10f32.powf(e);
        let (mut rect_err, mut s_err, mut tri_err) = (0f64, 0f64, 0f64);
        for _ in 0..300 {
            // Random orientation and aspect; distance d with size ~ sqrt(target)·d.
            let dir = random_unit(&mut rng);
            let ex0 = dir.any_orthonormal_vector();
            let ey0 = dir.cross(ex0);
            let rot = rng.next_f32() * std::f32::consts::TAU;
            let tilt = 0.2 + 0.8 * rng.next_f32(); // cos of the light's tilt
            let ex = (ex0 * rot.cos() + ey0 * rot.sin()) * tilt + dir * (1.0 - tilt * tilt).sqrt();
            let ey = dir.cross(ex).normalize();
            let ex = ex.normalize();
            let aspect = 0.3 + 2.0 * rng.next_f32();
            let dist = 10f32.powf(4.0 * rng.next_f32() - 2.0);
            let size = target.sqrt() * dist / tilt.sqrt();
            let (wx, wy) = (size * aspect.sqrt(), size / aspect.sqrt());
            let corner = dir * dist - 0.5 * wx * ex - 0.5 * wy * ey;
            let (exw, eyw) = (ex * wx, ey * wy);
            let c = corner.as_dvec3();
            let (dx, dy) = (exw.as_dvec3(), eyw.as_dvec3());
            let omega = vos(c, c + dx, c + dx + dy) + vos(c, c + dx + dy, c + dy);
            if let Some(r) = SphericalRect::new(corner, exw, eyw) {
                s_err = s_err.max((r.solid_angle() as f64 - omega).abs() / omega);
                for ux in [0.1f32, 0.5, 0.9] {
                    let q = r.sample(Vec2::new(ux, 0.5));
                    // Column coordinate along ex of the sample, as a fraction.
                    let s = ((q - corner).dot(ex) / wx) as f64;
                    let sub = vos(c, c + dx * s, c + dx * s + dy) + vos(c, c + dx * s + dy, c + dy);
                    rect_err = rect_err.max((sub / omega - ux as f64).abs());
                }
            }
            // Triangle: half of that rectangle.
            let (a, b, cc) = (corner, corner + exw, corner + exw + eyw);
            let om32 = spherical_tri::solid_angle(a, b, cc);
            let om = vos(a.as_dvec3(), b.as_dvec3(), cc.as_dvec3());
            for ux in [0.1f32, 0.5, 0.9] {
                // u.y = 1 ends the arc at the swept corner c'.
                let cp = spherical_tri::sample(
                    a.normalize(),
                    b.normalize(),
                    cc.normalize(),
                    om32,
                    Vec2::new(ux, 1.0),
                );
                let sub = vos(a.as_dvec3(), b.as_dvec3(), cp.as_dvec3() * dist as f64);
                tri_err = tri_err.max((sub / om - ux as f64).abs());
            }
        }
        println!("{target:9.1e}   {rect_err:11.2e}  {s_err:12.2e}  {tri_err:11.2e}");
    }
}
