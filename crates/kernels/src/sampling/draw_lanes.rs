//! A pixel's sample in eight lanes, one (pixel, sample) each, all lanes
//! on one light: one-sample MIS, either strategy (the light's own sampler,
//! Ureña's spherical rectangle or the fan of spherical triangles; or the
//! BRDF's lobes and the light's distance along the direction), its BRDF
//! value, both strategies' pdfs and the sample's weight. The light's data
//! (`PreparedLight`) is the same for every lane, read once per call, not
//! copied into the lanes. Each lane's arithmetic is the scalar estimator's
//! (`penumbra_render::estimate::samples`) operation by operation, so a
//! lane that reports `emit` holds exactly the direction, distance and
//! weight the scalar code computes for that pixel, at every ISA level and
//! lane width; the scalar code stays the definition (and the pixel
//! replay). A lane that is not `handled` (area sampling below
//! `SOLID_ANGLE_AREA_FALLBACK`) is for the caller to draw with the scalar
//! code: the kernel's answer for it means nothing.

use super::lanes8::{
    F, F3, FM, add3, clampc, cross, dot, ds, feq, finite, finite3, fmax, fnan, fs, max_element,
    mul3, narrow, normalize, scale3, select3, splat3, splat3d, sub3, widen,
};
use super::light::{
    EDGE_SLACK, LOBE_OFF_LIGHT_SHARE, MAX_TRIS, PreparedLight, SOLID_ANGLE_AREA_FALLBACK,
};
use super::spherical_rect::SphericalRectLanes;
use super::spherical_tri;
use super::trig;
use crate::shading::brdf::{MIN_ALPHA, MIN_COS, alpha_from_roughness};
use penumbra_scene::color::LUMA;
use std::f32::consts::{FRAC_1_PI, PI};

/// Eight samples on one light, structure of arrays: the pixels' G-buffer
/// samples and the samples' random numbers.
#[derive(Debug, Clone, Copy, Default)]
pub struct DrawLanesIn {
    /// 1 in lanes that hold a sample, 0 in the others (ignored). Flags
    /// are `f32` lanes, not `bool`s: a mask built from bytes kept LLVM
    /// from vectorising the selects that use it.
    pub active: F,
    /// The G-buffer sample: position, shading normal, view, material.
    pub p: F3,
    pub ns: F3,
    pub wo: F3,
    pub diffuse: F3,
    pub specular: F3,
    pub roughness: F,
    /// Probability of having chosen the light.
    pub p_choose: F,
    /// 1 where the specular lobe points away from the light, 0 elsewhere
    /// (`PreparedLight::lobe_misses`, decided by the caller).
    pub lobe_off: F,
    /// The sample's random numbers: strategy, lobe and direction.
    pub u_strategy: F,
    pub u_lobe: F,
    pub ux: F,
    pub uy: F,
}

/// The light the lanes sample: its prepared data, its radiance, and the
/// pixel's `1 / spp`.
#[derive(Debug, Clone, Copy)]
pub struct LanesLight<'a> {
    pub light: &'a PreparedLight,
    pub radiance: glam::Vec3,
    pub inv_spp: f32,
}

/// What the lanes drew. `handled` (1 or 0): the lane's sample is decided
/// here, either drawn or dropped as the scalar code drops it; elsewhere
/// (0) the caller draws it with the scalar code. `emit` (1 or 0): a
/// handled sample that was drawn, with its unit direction, distance to
/// the light and weight (`U_N`'s term, and `S_N`'s when its shadow ray is
/// unoccluded).
#[derive(Debug, Clone, Copy, Default)]
pub struct DrawLanesOut {
    pub handled: F,
    pub emit: F,
    pub wi: F3,
    pub dist: F,
    pub weight: F3,
}

/// glam's `Vec3::dot` with a constant.
#[inline(always)]
fn dot_c(a: &F3, c: glam::Vec3) -> F {
    a[0] * fs(c.x) + a[1] * fs(c.y) + a[2] * fs(c.z)
}

/// `ShadingBasis::to_local` per lane.
#[inline(always)]
fn to_local(v: &F3, x: &F3, y: &F3, z: &F3) -> F3 {
    [dot(v, x), dot(v, y), dot(v, z)]
}

/// `brdf_sample::spec_lobe_probability` per lane.
#[inline(always)]
fn spec_lobe_probability(diffuse: &F3, specular: &F3, n_dot_wo: F) -> F {
    let wd = fmax(dot_c(diffuse, LUMA), fs(0.0));
    let has = max_element(specular).gt(fs(0.0));
    let m = (fs(1.0) - clampc(n_dot_wo, 0.0, 1.0)).map(|x| x.powi(5));
    let one_minus = sub3(&[fs(1.0); 3], specular);
    let ws = fmax(
        dot_c(&add3(specular, &scale3(&one_minus, m)), LUMA),
        fs(0.0),
    );
    let ws = has.select(ws, fs(0.0));
    let total = wd + ws;
    total.gt(fs(0.0)).select(ws / total, fs(0.0))
}

/// `brdf::smith_lambda` per lane.
#[inline(always)]
fn smith_lambda(alpha: F, w: &F3) -> F {
    let cos2 = fmax(w[2] * w[2], fs(MIN_COS * MIN_COS));
    let sin2 = w[0] * w[0] + w[1] * w[1];
    let a = alpha * alpha * sin2 / cos2;
    a / (fs(2.0) * ((fs(1.0) + a).sqrt() + fs(1.0)))
}

/// `brdf::ggx_d` per lane, for lanes whose `h.z > 0` (the others: 0).
#[inline(always)]
fn ggx_d(alpha: F, h: &F3) -> F {
    let a2 = alpha * alpha;
    let t = h[0] * h[0] + h[1] * h[1] + a2 * h[2] * h[2];
    let d = a2 / (fs(PI) * t * t);
    h[2].le(fs(0.0)).select(fs(0.0), d)
}

/// `brdf::eval_local` per lane, for lanes whose `wi.z > 0`.
#[inline(always)]
fn eval_local(wi: &F3, wo: &F3, diffuse: &F3, specular: &F3, alpha: F) -> F3 {
    // spec_local: the half vector, D, G2.
    let h = add3(wi, wo);
    let l2 = dot(&h, &h);
    let h = [h[0] / l2.sqrt(), h[1] / l2.sqrt(), h[2] / l2.sqrt()];
    let d = ggx_d(alpha, &h);
    let g = fs(1.0) / (fs(1.0) + smith_lambda(alpha, wi) + smith_lambda(alpha, wo));
    let ci = fmax(wi[2], fs(MIN_COS));
    let co = fmax(wo[2].abs(), fs(MIN_COS));
    let s = d * g / (fs(4.0) * ci * co);
    let cos_oh = dot(wo, &h);
    let none = l2.gt(fs(1e-20)).invert().or(feq(d, fs(0.0)));
    let (s, cos_oh) = (none.select(fs(0.0), s), none.select(fs(0.0), cos_oh));
    // schlick(specular, cos_oh) * s, plus the diffuse lobe.
    let m = fs(1.0) - clampc(cos_oh, 0.0, 1.0);
    let m2 = m * m;
    let weight = m2 * m2 * m;
    let lambert = scale3(diffuse, fs(1.0 / PI));
    let fresnel = add3(specular, &scale3(&sub3(&[fs(1.0); 3], specular), weight));
    let full = add3(&lambert, &scale3(&fresnel, s));
    let has = max_element(specular).gt(fs(0.0));
    select3(has, &full, &lambert)
}

/// `brdf_sample::brdf_pdf_local` per lane.
#[inline(always)]
fn brdf_pdf_local(wo: &F3, wi: &F3, alpha: F, p_spec: F) -> F {
    // vndf_pdf
    let a = fmax(alpha, fs(MIN_ALPHA));
    let h = add3(wo, wi);
    let rcp = fs(1.0) / dot(&h, &h).sqrt();
    let h = scale3(&h, rcp);
    let v = fs(1.0) / (fs(1.0) + smith_lambda(a, wo)) * ggx_d(a, &h) / (fs(4.0) * wo[2]);
    let zero = wo[2]
        .le(fs(0.0))
        .or(finite(rcp).and(rcp.gt(fs(0.0))).invert())
        .or(dot(wo, &h).le(fs(0.0)))
        .or(h[2].le(fs(0.0)));
    let v = zero.select(fs(0.0), v);
    let spec = p_spec.gt(fs(0.0)).select(p_spec * v, fs(0.0));
    let diff = p_spec.lt(fs(1.0)).select(
        (fs(1.0) - p_spec) * fmax(wi[2], fs(0.0)) * fs(FRAC_1_PI),
        fs(0.0),
    );
    spec + diff
}

/// `brdf_sample::sample_brdf` per lane, less its final pdf test (the
/// caller's MIS pdf test covers it: a zero BRDF pdf makes the lane's
/// `brdf_pdf_local` zero too, and the scalar code drops both): the world
/// direction, and the lanes where it is defined.
#[inline(always)]
fn sample_brdf(n: &F3, wo: &F3, alpha: F, p_spec: F, u_lobe: F, ux: F, uy: F) -> (F3, FM) {
    // onb(n)
    let sign = fs(1.0).zip(n[2], f32::copysign);
    let a = fs(-1.0) / (sign + n[2]);
    let b = n[0] * n[1] * a;
    let t = [fs(1.0) + sign * n[0] * n[0] * a, sign * b, -sign * n[0]];
    let bb = [b, sign + n[1] * n[1] * a, -n[1]];
    let wo_l = [dot(wo, &t), dot(wo, &bb), dot(wo, n)];
    let spec = u_lobe.lt(p_spec);
    // vndf_sample(wo_l, alpha, u)
    let al = fmax(alpha, fs(MIN_ALPHA));
    let v = normalize(&[al * wo_l[0], al * wo_l[1], wo_l[2]]);
    let phi = fs(2.0 * PI) * ux;
    let z = (fs(1.0) - uy) * (fs(1.0) + v[2]) - v[2];
    let sin_theta = clampc(fs(1.0) - z * z, 0.0, 1.0).sqrt();
    // cosine_hemisphere(u)
    let ox = fs(2.0) * ux - fs(1.0);
    let oy = fs(2.0) * uy - fs(1.0);
    let centre = feq(ox, fs(0.0)).and(feq(oy, fs(0.0)));
    let wide = ox.abs().gt(oy.abs());
    let angle_d = wide.select(
        fs(PI / 4.0) * (oy / ox),
        fs(PI / 2.0) - fs(PI / 4.0) * (ox / oy),
    );
    // One sin_cos per lane: of the lobe's own angle.
    let (sa, ca) = trig::sin_cos_lanes(widen(spec.select(phi, angle_d)));
    let (sa, ca) = (narrow(sa), narrow(ca));
    let h = add3(&[sin_theta * ca, sin_theta * sa, z], &v);
    let h = normalize(&[al * h[0], al * h[1], fmax(h[2], fs(0.0))]);
    let k = fs(2.0) * dot(&wo_l, &h);
    let wi_spec = sub3(&scale3(&h, k), &wo_l);
    let r = wide.select(ox, oy);
    let d = [r * ca, r * sa];
    let d = [centre.select(fs(0.0), d[0]), centre.select(fs(0.0), d[1])];
    let dz = fmax(fs(1.0) - (d[0] * d[0] + d[1] * d[1]), fs(0.0)).sqrt();
    let wi_l = select3(spec, &wi_spec, &[d[0], d[1], dz]);
    let ok = wo_l[2].gt(fs(0.0)).and(wi_l[2].gt(fs(0.0)));
    let pdf = brdf_pdf_local(&wo_l, &wi_l, alpha, p_spec);
    let ok = ok.and(pdf.gt(fs(0.0))).and(finite(pdf));
    // to_world, normalized.
    let w = add3(
        &add3(&scale3(&t, wi_l[0]), &scale3(&bb, wi_l[1])),
        &scale3(n, wi_l[2]),
    );
    (normalize(&w), ok)
}

/// `PreparedLight::intersect_plane` per lane: the distance along `wi`,
/// and the lanes where it hits the emitting side.
#[inline(always)]
fn intersect(l: &PreparedLight, p: &F3, plane: F, wi: &F3) -> (F, FM) {
    let cos = dot(wi, &splat3(l.normal));
    let facing = feq(cos, fs(0.0)).invert();
    let facing = if l.two_sided {
        facing
    } else {
        facing.and(cos.gt(fs(0.0)).invert())
    };
    let t = plane / cos;
    let mut ok = facing.and(t.gt(fs(0.0))).and(finite(t));
    let q = scale3(wi, t);
    for e in 0..l.n {
        let a = sub3(&splat3(l.verts[e]), p);
        let len = fs(l.edge_len[e]);
        let tol = fs(EDGE_SLACK) * len * (t + len);
        ok = ok.and(dot(&splat3(l.inward[e]), &sub3(&q, &a)).lt(-tol).invert());
    }
    (t, ok)
}

/// What a light's sampler set up for the lanes (`LightSampler::new`):
/// its solid angle, the lanes where it exists, and the light strategy's
/// point relative to the shading point (`sample`, before its distance).
struct LightDraw {
    omega: F,
    ok: FM,
    q: F3,
}

/// `LightSampler::new` and `sample` per lane for a rectangle light.
#[inline(always)]
fn rect_draw(l: &PreparedLight, i: &DrawLanesIn) -> LightDraw {
    let Some((corner, frame)) = &l.rect else {
        unreachable!("rect_draw is only called for rectangle lights")
    };
    let (fx, fy, lx, ly) = frame.parts();
    let corner = sub3(&splat3(*corner), &i.p);
    let (rect, rect_ok) =
        SphericalRectLanes::from_frame(&corner, &splat3d(fx), &splat3d(fy), ds(lx), ds(ly));
    let omega = rect.solid_angle;
    let ok = narrow(rect_ok.select(ds(1.0), ds(0.0))).gt(fs(0.5));
    LightDraw {
        omega,
        ok,
        q: rect.sample(i.ux, i.uy),
    }
}

/// `LightSampler::new` and `sample` per lane for a fan of spherical
/// triangles (v0, vk, vk+1), `plane` the lanes' (v0 − p)·n.
#[inline(always)]
fn fan_draw(l: &PreparedLight, i: &DrawLanesIn, plane: F) -> LightDraw {
    let n = l.n;
    let nt = n - 2;
    // Solid angle per triangle, Van Oosterom–Strackee on the f64 vertices
    // relative to p, with the dot products the fan shares.
    // Plain loops: `array::from_fn` is compiled out of line, at baseline
    // whatever level the caller runs (`isa`).
    let mut rel = [[fs(0.0); 3]; 8];
    for (k, r) in rel.iter_mut().enumerate().take(n) {
        *r = sub3(&splat3(l.verts[k]), &i.p);
    }
    let mut relw = [[widen(fs(0.0)); 3]; 8];
    let mut len = [widen(fs(0.0)); 8];
    for k in 0..8 {
        relw[k] = [widen(rel[k][0]), widen(rel[k][1]), widen(rel[k][2])];
        len[k] = dot(&relw[k], &relw[k]).sqrt();
    }
    let mut tri = [fs(0.0); MAX_TRIS];
    let mut omega = fs(0.0);
    for k in 1..n - 1 {
        let triple = dot(&relw[0], &splat3d(l.fan_cross[k - 1])).abs();
        let d0k = dot(&relw[0], &relw[k]);
        let d0k1 = dot(&relw[0], &relw[k + 1]);
        let den = len[0] * len[k] * len[k + 1]
            + d0k * len[k + 1]
            + d0k1 * len[k]
            + dot(&relw[k], &relw[k + 1]) * len[0];
        let t = narrow(ds(2.0) * trig::atan2_lanes(triple, den));
        tri[k - 1] = finite(t).select(t, fs(0.0));
        omega = omega + tri[k - 1];
    }
    // `select`: the triangle by solid angle, and u.x rescaled within it.
    let mut later = FM::NONE;
    let mut is_last = [FM::NONE; MAX_TRIS];
    for k in (0..nt).rev() {
        let pos = tri[k].gt(fs(0.0)).or(fnan(tri[k]));
        is_last[k] = pos.and_not(later);
        later = later.or(pos);
    }
    let target = i.ux * omega;
    let mut acc = fs(0.0);
    let mut found = FM::NONE;
    let mut ux = i.ux;
    let mut w = fs(0.0);
    let (mut b, mut c) = (rel[1], rel[2]);
    for k in 0..nt {
        let next = acc + tri[k];
        let hit = found
            .invert()
            .and(tri[k].gt(fs(0.0)))
            .and(target.lt(next).or(is_last[k]));
        let x = clampc((target - acc) / tri[k], 0.0, 1.0 - f32::EPSILON / 2.0);
        ux = hit.select(x, ux);
        w = hit.select(tri[k], w);
        b = select3(hit, &rel[k + 1], &b);
        c = select3(hit, &rel[k + 2], &c);
        found = found.or(hit);
        acc = next;
    }
    let w = found.select(w, tri[0]);
    let dir = spherical_tri::sample_lanes(
        &normalize(&rel[0]),
        &normalize(&b),
        &normalize(&c),
        w,
        ux,
        i.uy,
    );
    // On the light's plane: the renderer needs the distance.
    let q = scale3(&dir, plane / dot(&dir, &splat3(l.normal)));
    LightDraw {
        omega,
        ok: FM::from_fn(|_| true),
        q,
    }
}

/// One sample of eight pixels on one light: the scalar estimator's
/// arithmetic per lane (see the module notes).
#[inline(always)]
pub fn draw_light_lanes(light: &LanesLight, i: &DrawLanesIn) -> DrawLanesOut {
    if light.light.rect.is_some() {
        draw_rect_lanes(light, i)
    } else {
        draw_fan_lanes(light, i)
    }
}

/// `draw_light_lanes` for a light that has a rectangle sampler.
#[inline(always)]
pub fn draw_rect_lanes(light: &LanesLight, i: &DrawLanesIn) -> DrawLanesOut {
    draw_with(light, i, true)
}

/// `draw_light_lanes` for a light sampled as a fan of spherical triangles.
#[inline(always)]
pub fn draw_fan_lanes(light: &LanesLight, i: &DrawLanesIn) -> DrawLanesOut {
    draw_with(light, i, false)
}

#[inline(always)]
fn draw_with(light: &LanesLight, i: &DrawLanesIn, rect: bool) -> DrawLanesOut {
    let l = light.light;
    let (n, wo) = (&i.ns, &i.wo);
    let alpha = i.roughness.map(alpha_from_roughness);
    let n_dot_wo = dot(n, wo);
    let p_spec = spec_lobe_probability(&i.diffuse, &i.specular, n_dot_wo);
    let two_alpha = fs(2.0) * alpha;
    let lobe_solid_angle = fs(4.0 * PI) * (two_alpha * two_alpha);
    // ShadingBasis::from_normal_view.
    let t = sub3(wo, &scale3(n, n_dot_wo));
    let l2 = dot(&t, &t);
    let tx = [t[0] / l2.sqrt(), t[1] / l2.sqrt(), t[2] / l2.sqrt()];
    let sign = n[2].map(f32::signum);
    let a = fs(-1.0) / (sign + n[2]);
    let b = n[0] * n[1] * a;
    let any = [b, sign + n[1] * n[1] * a, -n[1]];
    let fx = select3(l2.gt(fs(1e-12)), &tx, &any);
    let fy = cross(n, &fx);
    let wo_l = to_local(wo, &fx, &fy, n);
    // LightSampler::new: the plane test, then the light's own setup.
    let plane = dot(&sub3(&splat3(l.verts[0]), &i.p), &splat3(l.normal));
    let plane_ok = finite(plane).and(feq(plane, fs(0.0)).invert());
    let plane_ok = if l.two_sided {
        plane_ok
    } else {
        plane_ok.and(plane.gt(fs(0.0)).invert())
    };
    let ld = if rect {
        rect_draw(l, i)
    } else {
        fan_draw(l, i, plane)
    };
    let omega = ld.omega;
    let sampler_ok = plane_ok
        .and(ld.ok)
        .and(omega.gt(fs(0.0)))
        .and(finite(omega));
    // Below the fallback solid angle the scalar sampler samples by area.
    let area = sampler_ok.and(omega.lt(fs(SOLID_ANGLE_AREA_FALLBACK)));
    // light_strategy_probability, and the light strategy's draw.
    let spec = i.lobe_off.gt(fs(0.0)).select(
        fs(LOBE_OFF_LIGHT_SHARE),
        clampc(lobe_solid_angle / (lobe_solid_angle + omega), 0.1, 0.9),
    );
    let p_light = p_spec
        .le(fs(0.0))
        .select(fs(1.0), (fs(1.0) - p_spec) + p_spec * spec);
    let use_light = p_light.ge(fs(1.0)).or(i.u_strategy.lt(p_light));
    let q = ld.q;
    let dist_l = dot(&q, &q).sqrt();
    let wi_light = [q[0] / dist_l, q[1] / dist_l, q[2] / dist_l];
    // The BRDF strategy: a direction from the lobes, then the light's
    // distance and pdf along it (`LightSampler::pdf`).
    let (wi_brdf, brdf_ok) = sample_brdf(n, wo, alpha, p_spec, i.u_lobe, i.ux, i.uy);
    let (dist_b, hit) = intersect(l, &i.p, plane, &wi_brdf);
    let wi = select3(use_light, &wi_light, &wi_brdf);
    let dist = use_light.select(dist_l, dist_b);
    let drawn = use_light.or(brdf_ok.and(hit));
    let pdf_light = fs(1.0) / omega;
    let valid = finite(pdf_light)
        .and(pdf_light.gt(fs(0.0)))
        .and(finite(dist))
        .and(dist.gt(fs(0.0)));
    let cos = dot(n, &wi);
    let wi_l = to_local(&wi, &fx, &fy, n);
    let pdf_brdf = p_light
        .lt(fs(1.0))
        .select(brdf_pdf_local(&wo_l, &wi_l, alpha, p_spec), fs(0.0));
    let pdf = p_light * pdf_light + (fs(1.0) - p_light) * pdf_brdf;
    let f = eval_local(&wi_l, &wo_l, &i.diffuse, &i.specular, alpha);
    let k = cos * fs(light.inv_spp) / (i.p_choose * pdf);
    let w = scale3(&mul3(&f, &splat3(light.radiance)), k);
    let pdf_ok = pdf.gt(fs(0.0)).and(finite(pdf));
    let w_ok = finite3(&w).and(max_element(&w).gt(fs(0.0)));
    let handled = i.active.gt(fs(0.5)).and_not(area);
    let emit = handled
        .and(sampler_ok)
        .and(drawn)
        .and(valid)
        .and(cos.gt(fs(0.0)))
        .and(pdf_ok)
        .and(w_ok);
    let flag = |m: FM| m.select(fs(1.0), fs(0.0));
    DrawLanesOut {
        handled: flag(handled),
        emit: flag(emit),
        wi,
        dist,
        weight: w,
    }
}
