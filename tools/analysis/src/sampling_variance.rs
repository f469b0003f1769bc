//! How well each model's own sampler serves a renderer: the variance of the one-sample
//! estimator of reflected radiance under an environment map,
//!
//!   L_o(wo) = int L(wi) f(wo, wi) cos(theta_i) dwi  ~  L(wi) f cos / p(wi),  wi ~ p,
//!
//! with `p` the model's BSDF sampling, relative to the same estimator with a near-ideal
//! proposal: the luminance of f cos tabulated on a fine grid over the hemisphere (equal
//! steps in theta and phi, piecewise constant, sampled uniformly in solid angle inside a
//! cell),
//! whose weight f cos / p is almost constant, so that its variance is mostly the map's.
//! A ratio of 1 is as good as importance sampling of the BRDF can be; above 1 the
//! sampler wastes samples (directions where f cos is small, lost samples below the
//! horizon). Luminance throughout; the surface normal is +z in the map's frame (the
//! upper hemisphere of the map lights it), `wo` at the elevations of [`VIEWS`] in the
//! xz plane. The estimates use a fixed seed (the same table every run).

use lobe_materials::Bsdf;
use lobe_materials::sampling::random::{hash, unit};
use lobe_renderer::lights::envmap::EnvMap;

/// Viewing elevations (degrees from the normal) of the table.
pub const VIEWS: [f64; 4] = [0.0, 45.0, 70.0, 85.0];

/// Cells of the tabulated proposal in theta and in phi (0.18 by 0.35 degrees).
const GRID: (usize, usize) = (512, 1024);

/// Mean and variance of a one-sample estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    pub mean: f64,
    pub variance: f64,
}

fn moments(values: impl Iterator<Item = f64>) -> Moments {
    let (mut n, mut s, mut s2) = (0.0f64, 0.0f64, 0.0f64);
    for v in values {
        n += 1.0;
        s += v;
        s2 += v * v;
    }
    let mean = s / n.max(1.0);
    Moments {
        mean,
        variance: (s2 / n.max(1.0) - mean * mean).max(0.0) * n / (n - 1.0).max(1.0),
    }
}

/// The i-th uniform triple of stream `k`.
fn uniform(k: u64, i: u64) -> (f32, f32, f32) {
    let h = hash(k, i);
    let u = |j: u64| (unit(hash(h, j)) as f32).min(1.0 - f32::EPSILON);
    (u(0), u(1), u(2))
}

/// The map's luminance towards `wi` (local = the map's frame).
fn radiance(env: &EnvMap, wi: glam::Vec3) -> f64 {
    env.eval(wi).luminance() as f64
}

/// The one-sample estimator of the model's own sampling at `wo`, over `n` samples (a lost
/// sample counts as zero).
pub fn own_sampling(bsdf: &dyn Bsdf, env: &EnvMap, wo: glam::Vec3, n: usize) -> Moments {
    moments((0..n as u64).map(|i| {
        let (a, b, c) = uniform(1, i);
        bsdf.sample(wo, glam::Vec2::new(a, b), c)
            .map_or(0.0, |s| radiance(env, s.wi) * s.weight.luminance() as f64)
    }))
}

/// The one-sample estimator of the tabulated f cos proposal at `wo`, over `n` samples.
pub fn tabulated_sampling(bsdf: &dyn Bsdf, env: &EnvMap, wo: glam::Vec3, n: usize) -> Moments {
    let (nt, np) = GRID;
    let dphi = std::f64::consts::TAU / np as f64;
    // cos(theta) at the bin edges; a cell's solid angle is (cos_i - cos_(i+1)) dphi.
    let edge: Vec<f64> = (0..=nt)
        .map(|i| (i as f64 / nt as f64 * std::f64::consts::FRAC_PI_2).cos())
        .collect();
    let dir = |ct: f64, phi: f64| {
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        glam::Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32)
    };
    // The point of cell (i, j) at fractions (a, b) of its cos(theta) and phi ranges.
    let at = |i: usize, j: usize, a: f64, b: f64| {
        let ct = edge[i] + a * (edge[i + 1] - edge[i]);
        (ct, (j as f64 + b) * dphi)
    };
    // Cell masses from f cos at 2 x 2 points per cell times the cell's solid angle (the
    // mass is what matters, not an exact integral: any positive table is an unbiased
    // proposal).
    let mass: Vec<f64> = (0..nt * np)
        .map(|k| {
            let (i, j) = (k / np, k % np);
            let mut m = 0.0;
            for (a, b) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let (ct, phi) = at(i, j, a, b);
                m += bsdf.eval(wo, dir(ct, phi)).luminance() as f64 * ct;
            }
            let solid_angle = (edge[i] - edge[i + 1]) * dphi;
            // A floor keeps every cell reachable (the proposal must cover f cos > 0).
            (m / 4.0 + 1e-9) * solid_angle
        })
        .collect();
    let total: f64 = mass.iter().sum();
    let mut cdf = Vec::with_capacity(mass.len());
    let mut acc = 0.0;
    for m in &mass {
        acc += m / total;
        cdf.push(acc);
    }
    moments((0..n as u64).map(|s| {
        let (a, b, c) = uniform(2, s);
        let k = cdf.partition_point(|&v| v < a as f64).min(mass.len() - 1);
        let (i, j) = (k / np, k % np);
        let (ct, phi) = at(i, j, b as f64, c as f64);
        let wi = dir(ct, phi);
        let pdf = mass[k] / total / ((edge[i] - edge[i + 1]) * dphi);
        let f = bsdf.eval(wo, wi).luminance() as f64;
        radiance(env, wi) * f * ct / pdf
    }))
}

/// The view direction at `degrees` from the normal, in the xz plane.
pub fn view(degrees: f64) -> glam::Vec3 {
    let t = degrees.to_radians();
    glam::Vec3::new(t.sin() as f32, 0.0, t.cos() as f32)
}

/// Per view of [`VIEWS`]: (the model's own sampling, the tabulated proposal), `n`
/// samples each.
pub fn table_row(bsdf: &dyn Bsdf, env: &EnvMap, n: usize) -> Vec<(Moments, Moments)> {
    VIEWS
        .iter()
        .map(|&d| {
            let wo = view(d);
            (
                own_sampling(bsdf, env, wo, n),
                tabulated_sampling(bsdf, env, wo, n),
            )
        })
        .collect()
}
