//! Warps from the unit square to directions, triangles and bilinear patches, with their
//! densities: the standard constructions of pbrt-v4 (`util/sampling.h`) and Mitsuba 3
//! (`core/warp.h`), written from Shirley and Chiu's concentric map ("A Low Distortion Map
//! Between Disk and Square", 1997), Malley's method for the cosine-weighted hemisphere and
//! pbrt-v4's `SampleLinear`/`SampleBilinear`; and Veach's power heuristic (1997,
//! beta = 2) that weighs two such strategies in multiple importance sampling.

use crate::fastmath::xn;
use crate::simd;
use crate::simd::f32xn;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// Concentric square-to-disk map (Shirley and Chiu 1997). Both wedges' angles are
/// computed and one is selected, with no branch: which wedge a uniform point falls in is a
/// coin flip the branch predictor would miss half the time.
#[inline]
pub fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    let wide = o.x.abs() > o.y.abs();
    let r = crate::fastmath::select(wide, o.x, o.y);
    let theta_x = FRAC_PI_4 * (o.y / o.x);
    let theta_y = FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y);
    let theta = crate::fastmath::select(wide, theta_x, theta_y);
    // |theta| <= 3 pi / 4 (NaN only at the centre, which is replaced below).
    let (s, c) = crate::fastmath::sin_cos_moderate(theta);
    let d = Vec2::new(r * c, r * s);
    if o.x == 0.0 && o.y == 0.0 {
        Vec2::ZERO
    } else {
        d
    }
}

/// [`square_to_disk_concentric`] in SIMD lanes, with the same operations (bit for bit
/// the same).
#[inline(always)]
pub fn square_to_disk_concentric_xn(ux: f32xn, uy: f32xn) -> (f32xn, f32xn) {
    let (one, two, zero) = (f32xn::splat(1.0), f32xn::splat(2.0), f32xn::splat(0.0));
    let (ox, oy) = (two * ux - one, two * uy - one);
    let wide = ox.abs().simd_gt(oy.abs());
    let r = simd::sel(wide, ox, oy);
    let theta_x = f32xn::splat(FRAC_PI_4) * (oy / ox);
    let theta_y = f32xn::splat(FRAC_PI_2) - f32xn::splat(FRAC_PI_4) * (ox / oy);
    let theta = simd::sel(wide, theta_x, theta_y);
    let (s, c) = xn::sin_cos_moderate(theta);
    let centre = ox.simd_eq(zero) & oy.simd_eq(zero);
    (
        simd::sel(centre, zero, r * c),
        simd::sel(centre, zero, r * s),
    )
}

/// [`square_to_cosine_hemisphere`] in SIMD lanes (bit for bit the same): (x, y, z).
#[inline(always)]
pub fn square_to_cosine_hemisphere_xn(ux: f32xn, uy: f32xn) -> [f32xn; 3] {
    let (x, y) = square_to_disk_concentric_xn(ux, uy);
    let z = (f32xn::splat(1.0) - (x * x + y * y))
        .max(f32xn::splat(0.0))
        .sqrt();
    [x, y, z]
}

/// Cosine-weighted hemisphere around +z (Malley's method).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    // `max_lane`: the same as the SIMD forms' `max` for -0.0 too.
    simd::max_lane(cos_theta, 0.0) * FRAC_1_PI
}

/// [`cosine_hemisphere_pdf`] per lane.
#[inline(always)]
pub fn cosine_hemisphere_pdf_xn(cos_theta: f32xn) -> f32xn {
    cos_theta.max(f32xn::splat(0.0)) * f32xn::splat(FRAC_1_PI)
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = crate::fastmath::sin_cos(TAU * u.x);
    Vec3::new(r * c, r * s, z)
}

pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction in the cone of half-angle acos(cos_max) around +z.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = (1.0 - u.y) + u.y * cos_max;
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (s, c) = crate::fastmath::sin_cos(TAU * u.x);
    Vec3::new(sin_t * c, sin_t * s, cos_t)
}

#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (TAU * (1.0 - cos_max))
}

/// Uniform barycentrics (b1, b2) on a triangle (the square-root parameterization).
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// Power heuristic with beta = 2 (Veach 1997) for two strategies with one sample each.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a2 = pdf_a * pdf_a;
    let b2 = pdf_b * pdf_b;
    if a2.is_infinite() {
        return 1.0;
    }
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// Samples x in [0, 1] with density proportional to the linear ramp (1 - x) a + x b
/// (a, b >= 0): the inverse of its CDF, written as in pbrt-v4's `SampleLinear` so that
/// it does not cancel when a and b are close.
#[inline]
pub fn sample_linear(u: f32, a: f32, b: f32) -> f32 {
    if u == 0.0 && a == 0.0 {
        return 0.0;
    }
    let denom = a + ((1.0 - u) * a * a + u * b * b).max(0.0).sqrt();
    if !(denom > 0.0) {
        return u;
    }
    (u * (a + b) / denom).min(1.0 - f32::EPSILON / 2.0)
}

/// Samples the unit square with density proportional to the bilinear interpolation of
/// the corner weights `w` = [w(0,0), w(1,0), w(0,1), w(1,1)] (all >= 0, not all zero):
/// y from the marginal ramp, then x from the ramp conditional on y. Monotone in each
/// coordinate of `u`, so stratified samples stay stratified.
#[inline]
pub fn square_to_bilinear(u: Vec2, w: [f32; 4]) -> Vec2 {
    let y = sample_linear(u.y, w[0] + w[1], w[2] + w[3]);
    let x = sample_linear(u.x, w[0] + (w[2] - w[0]) * y, w[1] + (w[3] - w[1]) * y);
    Vec2::new(x, y)
}

/// [`sample_linear`] in SIMD lanes, with the same operations (bit for bit the same).
#[inline(always)]
pub fn sample_linear_xn(u: f32xn, a: f32xn, b: f32xn) -> f32xn {
    let (zero, one) = (f32xn::splat(0.0), f32xn::splat(1.0));
    let denom = a + ((one - u) * a * a + u * b * b).max(zero).sqrt();
    let x = (u * (a + b) / denom).min(f32xn::splat(1.0 - f32::EPSILON / 2.0));
    let x = simd::sel(denom.simd_gt(zero), x, u);
    simd::sel(u.simd_eq(zero) & a.simd_eq(zero), zero, x)
}

/// [`square_to_bilinear`] in SIMD lanes (bit for bit the same): `w` holds the corner
/// weights of each lane.
#[inline(always)]
pub fn square_to_bilinear_xn(ux: f32xn, uy: f32xn, w: [f32xn; 4]) -> (f32xn, f32xn) {
    let y = sample_linear_xn(uy, w[0] + w[1], w[2] + w[3]);
    let x = sample_linear_xn(ux, w[0] + (w[2] - w[0]) * y, w[1] + (w[3] - w[1]) * y);
    (x, y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::LANES;

    #[test]
    fn warps_land_where_they_should() {
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0);
                assert!(square_to_disk_concentric(u).length() <= 1.0 + 1e-6);
                let w = square_to_cosine_hemisphere(u);
                assert!(w.z >= 0.0 && (w.length() - 1.0).abs() < 1e-5);
                assert!((square_to_uniform_sphere(u).length() - 1.0).abs() < 1e-5);
                let c = square_to_uniform_cone(u, 0.9);
                assert!(c.z >= 0.9 - 1e-6);
                let b = square_to_uniform_triangle(u);
                assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            }
        }
    }

    #[test]
    fn power_heuristic_limits() {
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-7);
        assert_eq!(power_heuristic(f32::INFINITY, 3.0), 1.0);
    }

    /// Density of [`square_to_bilinear`] at `p` (the renderer computes it with the cell's
    /// other terms: `EnvMap::pdf`).
    fn bilinear_pdf(p: Vec2, w: [f32; 4]) -> f32 {
        let sum = w[0] + w[1] + w[2] + w[3];
        if !(sum > 0.0) {
            return 1.0;
        }
        let top = w[0] + (w[1] - w[0]) * p.x;
        let bottom = w[2] + (w[3] - w[2]) * p.x;
        4.0 * (top + (bottom - top) * p.y) / sum
    }

    /// The bilinear warp draws points with the density `bilinear_pdf` says (histogram of a
    /// fine stratified grid of u against the density integrated over each bin), for
    /// ordinary, degenerate (zero corners) and nearly equal corner weights.
    #[test]
    fn bilinear_warp_matches_its_density() {
        for w in [
            [1.0, 2.0, 3.0, 4.0],
            [0.0, 0.0, 1.0, 0.0],
            [5.0, 0.0, 0.0, 5.0],
            [1.0, 1.0 + 1e-6, 1.0, 1.0],
            [1e-30, 1.0, 1.0, 1e-30],
        ] {
            let (n, m) = (8usize, 512usize);
            let mut hist = vec![0u32; n * n];
            for i in 0..m {
                for j in 0..m {
                    let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                    let p = square_to_bilinear(u, w);
                    assert!(
                        (0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y),
                        "{p}"
                    );
                    let pdf = bilinear_pdf(p, w);
                    assert!(pdf.is_finite() && pdf >= 0.0);
                    hist[(p.y * n as f32) as usize * n + (p.x * n as f32) as usize] += 1;
                }
            }
            for by in 0..n {
                for bx in 0..n {
                    // Midpoint rule is exact for the bilinear density.
                    let c = Vec2::new((bx as f32 + 0.5) / n as f32, (by as f32 + 0.5) / n as f32);
                    let expect = bilinear_pdf(c, w) / (n * n) as f32 * (m * m) as f32;
                    let got = hist[by * n + bx] as f32;
                    assert!(
                        (got - expect).abs() <= 0.01 * expect + 2.0 * m as f32 / n as f32,
                        "{w:?} bin ({bx}, {by}): {got} vs {expect}"
                    );
                }
            }
        }
    }
    /// The lane bilinear warp equals the scalar one bit for bit, including the
    /// degenerate ramps (zero weights, zero u).
    #[test]
    fn bilinear_xn_is_bit_identical() {
        let ws = [
            [1.0, 2.0, 3.0, 4.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 5.0, 0.0, 5.0],
            [1e-30, 1.0, 1e30, 0.5],
            [0.3, 0.3, 0.3, 0.3],
            [7.0, 0.0, 0.0, 0.0],
        ];
        for (k, w) in ws.iter().enumerate() {
            for j in 0..257 {
                let us: [Vec2; LANES] = std::array::from_fn(|i| {
                    let t = (j * LANES + i) as f32;
                    if j == 0 {
                        Vec2::new(i as f32 / 7.0, (7 - i) as f32 / 7.0)
                    } else {
                        Vec2::new((t * 0.618_034).fract(), (t * 0.754_878 + k as f32).fract())
                    }
                });
                let (x, y) = square_to_bilinear_xn(
                    f32xn::new(us.map(|u| u.x)),
                    f32xn::new(us.map(|u| u.y)),
                    w.map(f32xn::splat),
                );
                let (x, y) = (x.to_array(), y.to_array());
                for i in 0..LANES {
                    let e = square_to_bilinear(us[i], *w);
                    assert!(
                        x[i].to_bits() == e.x.to_bits() && y[i].to_bits() == e.y.to_bits(),
                        "{w:?} at {:?}: ({}, {}) against {e:?}",
                        us[i],
                        x[i],
                        y[i]
                    );
                }
            }
        }
    }
    /// The lane cosine warp equals the scalar one bit for bit, including the centre
    /// and the diagonals of the square.
    #[test]
    fn cosine_hemisphere_xn_is_bit_identical() {
        let mut us: Vec<Vec2> = (0..=64)
            .flat_map(|i| (0..=64).map(move |j| Vec2::new(i as f32 / 64.0, j as f32 / 64.0)))
            .collect();
        us.extend((0..4000).map(|k| {
            let t = k as f32;
            Vec2::new((t * 0.618_034).fract(), (t * 0.754_878).fract())
        }));
        us.push(Vec2::splat(0.5));
        for c in us.chunks(LANES) {
            let u = std::array::from_fn::<Vec2, LANES, _>(|i| c[i.min(c.len() - 1)]);
            let [x, y, z] = square_to_cosine_hemisphere_xn(
                f32xn::new(u.map(|u| u.x)),
                f32xn::new(u.map(|u| u.y)),
            );
            let (x, y, z) = (x.to_array(), y.to_array(), z.to_array());
            for i in 0..LANES {
                let e = square_to_cosine_hemisphere(u[i]);
                assert_eq!(
                    [x[i], y[i], z[i]].map(f32::to_bits),
                    [e.x, e.y, e.z].map(f32::to_bits),
                    "at {:?}",
                    u[i]
                );
            }
        }
    }
}
