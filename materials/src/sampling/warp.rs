//! Warps from the unit square to directions, triangles and bilinear patches, with their
//! densities: the standard constructions of pbrt-v4 (`util/sampling.h`) and Mitsuba 3
//! (`core/warp.h`), written from Shirley and Chiu's concentric map ("A Low Distortion Map
//! Between Disk and Square", 1997), Malley's method for the cosine-weighted hemisphere and
//! pbrt-v4's `SampleLinear`/`SampleBilinear`; and Veach's power heuristic (1997,
//! beta = 2) that weighs two such strategies in multiple importance sampling.

use crate::math::{Num, abs, eq, gt, maximum, minimum, select, sin_cos, sqrt};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// Concentric square-to-disk map (Shirley and Chiu 1997) of `u` = (`ux`, `uy`), written
/// once for one point and lanes. Both wedges' angles are computed and one is selected,
/// with no branch: which wedge a uniform point falls in is a coin flip the branch
/// predictor would miss half the time.
#[inline(always)]
pub fn disk_concentric<T: Num>(ux: T, uy: T) -> (T, T) {
    let (one, two, zero) = (T::of(1.0), T::of(2.0), T::of(0.0));
    let (ox, oy) = (two * ux - one, two * uy - one);
    let wide = gt(abs(ox), abs(oy));
    let r = select(wide, ox, oy);
    let quarter = T::of(std::f64::consts::FRAC_PI_4);
    let theta_x = quarter * (oy / ox);
    let theta_y = T::of(std::f64::consts::FRAC_PI_2) - quarter * (ox / oy);
    // |theta| <= 3 pi / 4 (NaN only at the centre, which is replaced below).
    let (s, c) = sin_cos(select(wide, theta_x, theta_y));
    let centre = eq(ox, zero) & eq(oy, zero);
    (select(centre, zero, r * c), select(centre, zero, r * s))
}

/// [`disk_concentric`] of one point.
#[inline]
pub fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    let (x, y) = disk_concentric(u.x, u.y);
    Vec2::new(x, y)
}

/// Cosine-weighted direction (x, y, z) about +z (Malley's method), written once for one
/// point and lanes.
#[inline(always)]
pub fn cosine_hemisphere<T: Num>(ux: T, uy: T) -> [T; 3] {
    let (x, y) = disk_concentric(ux, uy);
    let z = sqrt(maximum(T::of(1.0) - (x * x + y * y), T::of(0.0)));
    [x, y, z]
}

/// [`cosine_hemisphere`] of one point.
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    Vec3::from_array(cosine_hemisphere(u.x, u.y))
}

/// Density of [`cosine_hemisphere`] (solid angle): max(cos theta, 0) / pi.
#[inline(always)]
pub fn cosine_hemisphere_pdf<T: Num>(cos_theta: T) -> T {
    maximum(cos_theta, T::of(0.0)) * T::of(FRAC_1_PI as f64)
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
/// it does not cancel when a and b are close; once for one value and lanes.
#[inline(always)]
pub fn sample_linear<T: Num>(u: T, a: T, b: T) -> T {
    let (zero, one) = (T::of(0.0), T::of(1.0));
    let denom = a + sqrt(maximum((one - u) * a * a + u * b * b, zero));
    let x = minimum(
        u * (a + b) / denom,
        T::of((1.0 - f32::EPSILON / 2.0) as f64),
    );
    let x = select(gt(denom, zero), x, u);
    select(eq(u, zero) & eq(a, zero), zero, x)
}

/// Samples the unit square with density proportional to the bilinear interpolation of
/// the corner weights `w` = [w(0,0), w(1,0), w(0,1), w(1,1)] (all >= 0, not all zero):
/// y from the marginal ramp, then x from the ramp conditional on y. Monotone in each
/// coordinate of `u`, so stratified samples stay stratified. Once for one point and
/// lanes (`w` holds each lane's weights).
#[inline(always)]
pub fn bilinear<T: Num>(ux: T, uy: T, w: [T; 4]) -> (T, T) {
    let y = sample_linear(uy, w[0] + w[1], w[2] + w[3]);
    let x = sample_linear(ux, w[0] + (w[2] - w[0]) * y, w[1] + (w[3] - w[1]) * y);
    (x, y)
}

/// [`bilinear`] of one point.
#[inline]
pub fn square_to_bilinear(u: Vec2, w: [f32; 4]) -> Vec2 {
    let (x, y) = bilinear(u.x, u.y, w);
    Vec2::new(x, y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::{LANES, f32xn};

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
    fn bilinear_lanes_equal_one_point() {
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
                let (x, y) = bilinear(
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
    fn cosine_hemisphere_lanes_equal_one_point() {
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
            let [x, y, z] =
                cosine_hemisphere(f32xn::new(u.map(|u| u.x)), f32xn::new(u.map(|u| u.y)));
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
