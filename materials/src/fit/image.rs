//! The `image` fitting metric: the RMS difference between a render of the fit and a render
//! of the measured material, on a sphere under one or more environment maps (the study's
//! own future work, Ngan et al. 2005 section 7: "a perceptually-based metric would improve
//! the visual quality of the fits").
//!
//! The sphere is seen by a distant (orthographic) camera looking down -z, so pixel (x, y)
//! of the unit disk shows the normal n = (x, y, sqrt(1 - x^2 - y^2)) viewed from
//! wo = +z, and its value is the reflected radiance
//!
//!   I = int L(wi) f(wi, wo) max(0, n.wi) dwi
//!
//! (a convex sphere does not shadow itself). It is estimated once, with directions fixed
//! for every evaluation of the fit (common random numbers), so the objective is a smooth,
//! deterministic function of the lobe parameters that SLSQP can differentiate: per pixel,
//! half the directions importance-sample the environment map and half a mixture of
//! Phong-like cones cos^e around the mirror direction (e = 8, 64, 512, 4096: so sharp
//! highlights are resolved whatever the lobe's width), combined by the balance heuristic
//! (Veach's multi-sample estimator: each sample weighted by L cos / (n_env p_env + n_cone
//! p_cone), unbiased for any BRDF). Each sample stores (wo, wi) in the normal's frame and
//! its weight, so a render is a weighted sum of BRDF values: linear in the colours, which
//! come from NNLS per channel on the pixels ([`SphereImages::colours`]), as in Eq. (1).
//!
//! The environment maps reach this crate through [`Environment`] (the renderer's
//! `EnvMap` implements it in lobe-analysis), so the fitting library needs no renderer.

use super::linear::Gram;
use crate::frame::Frame;
use crate::lobe::Lobe;
use crate::sampling::mirror_cones;
use crate::sampling::random::{hash, unit};
use glam::{DVec3, Vec3};
use std::f64::consts::FRAC_1_PI;
use std::sync::Arc;

/// An environment map as the image metric samples it (world directions, +y up).
pub trait Environment: Sync {
    /// A direction drawn from the map's distribution for the uniform point `u`: the
    /// direction (unit, pointing away from the scene), its radiance and solid-angle
    /// density; None when nothing is drawn.
    fn sample(&self, u: [f64; 2]) -> Option<(Vec3, [f64; 3], f64)>;
    /// The radiance from direction `d` and the density with which `sample` draws it.
    fn eval_pdf(&self, d: Vec3) -> ([f64; 3], f64);
}

/// The size of the renders of the image metric.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSettings {
    /// Pixels across the sphere's square (the disk keeps about 79 % of them).
    pub resolution: usize,
    /// Directions per pixel (half from the map, half around the mirror direction).
    pub samples: usize,
}

impl Default for ImageSettings {
    fn default() -> Self {
        Self {
            resolution: 32,
            samples: 64,
        }
    }
}

/// Point k of n of a Hammersley set, shifted by `rot` modulo 1 (Cranley-Patterson).
fn hammersley(k: usize, n: usize, rot: [f64; 2]) -> [f64; 2] {
    let u = (k as f64 + 0.5) / n as f64;
    let v = (k as u32).reverse_bits() as f64 * (1.0 / 4_294_967_296.0);
    [(u + rot[0]).fract(), (v + rot[1]).fract()]
}

/// A sample: (wo, wi) in the normal's frame and its weight per channel.
type WeightedPair = ((DVec3, DVec3), [f64; 3]);

/// Renders of a sphere under environment maps as fixed weighted sums of BRDF values, and
/// the reference render of the measured material.
#[derive(Clone, Debug, Default)]
pub struct SphereImages {
    /// Sample range of each pixel: pixel p owns `offsets[p]..offsets[p + 1]`.
    offsets: Vec<usize>,
    /// (wo, wi) of each sample in the normal's frame, as `Lobe::eval_f64_many` takes them.
    pairs: Vec<(DVec3, DVec3)>,
    /// L cos / (n_env p_env + n_cone p_cone) of each sample, per channel.
    weights: Vec<[f64; 3]>,
    /// The render of the measured material, per pixel.
    reference: Vec<[f64; 3]>,
}

impl SphereImages {
    /// The samples of the sphere under each of `envs` (pixels of every map in turn); the
    /// reference is black until [`SphereImages::with_reference`].
    pub fn new(envs: &[&dyn Environment], settings: ImageSettings) -> Self {
        use rayon::prelude::*;
        let res = settings.resolution.max(1);
        let n_env = (settings.samples / 2).max(1);
        let n_cone = settings.samples.saturating_sub(n_env).max(1);
        let mut normals = Vec::new();
        for j in 0..res {
            for i in 0..res {
                let x = (i as f64 + 0.5) / res as f64 * 2.0 - 1.0;
                let y = 1.0 - (j as f64 + 0.5) / res as f64 * 2.0;
                let r2 = x * x + y * y;
                if r2 < 1.0 {
                    normals.push(DVec3::new(x, y, (1.0 - r2).sqrt()));
                }
            }
        }
        let pixels: Vec<(usize, DVec3)> = (0..envs.len())
            .flat_map(|e| normals.iter().map(move |n| (e, *n)))
            .collect();
        let per_pixel: Vec<Vec<WeightedPair>> = pixels
            .par_iter()
            .enumerate()
            .map(|(p, &(e, n))| pixel_samples(envs[e], n, p as u64, (n_env, n_cone)))
            .collect();
        let mut out = SphereImages {
            offsets: vec![0],
            ..Default::default()
        };
        for s in per_pixel {
            for (pair, w) in s {
                out.pairs.push(pair);
                out.weights.push(w);
            }
            out.offsets.push(out.pairs.len());
        }
        out.reference = vec![[0.0; 3]; out.pixels()];
        out
    }

    pub fn pixels(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Directions evaluated per render (every pixel's samples).
    pub fn samples(&self) -> usize {
        self.pairs.len()
    }

    /// The render of BRDF `f(wi, wo)` (per channel, cosine not included): each pixel's value.
    pub fn render(&self, f: &(dyn Fn(Vec3, Vec3) -> [f64; 3] + Sync)) -> Vec<[f64; 3]> {
        use rayon::prelude::*;
        (0..self.pixels())
            .into_par_iter()
            .map(|p| {
                let mut acc = [0.0; 3];
                for s in self.offsets[p]..self.offsets[p + 1] {
                    let (wo, wi) = self.pairs[s];
                    let v = f(wi.as_vec3(), wo.as_vec3());
                    for c in 0..3 {
                        if v[c].is_finite() {
                            acc[c] += v[c] * self.weights[s][c];
                        }
                    }
                }
                acc
            })
            .collect()
    }

    /// These images with the render of the measured material `f(wi, wo)` as reference.
    pub fn with_reference(mut self, f: &(dyn Fn(Vec3, Vec3) -> [f64; 3] + Sync)) -> Self {
        self.reference = self.render(f);
        self
    }

    pub fn reference(&self) -> &[[f64; 3]] {
        &self.reference
    }

    /// RMS difference of a render from the reference, over pixels and channels.
    pub fn error_of(&self, image: &[[f64; 3]]) -> f64 {
        let sum: f64 = image
            .iter()
            .zip(&self.reference)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>())
            .sum();
        (sum / (3.0 * self.pixels().max(1) as f64)).sqrt()
    }

    /// For fixed lobes (at most two), the non-negative colours whose render is nearest the
    /// reference (NNLS per channel over the pixels), and that RMS error: (error, [diffuse,
    /// specular of each lobe]).
    pub fn colours(&self, lobes: &[Arc<dyn Lobe>]) -> (f64, [[f64; 3]; 3]) {
        use rayon::prelude::*;
        assert!(lobes.len() <= 2, "at most two lobes");
        let n = 1 + lobes.len();
        // Each pixel's basis images in parallel (diffuse 1/pi, then each lobe at unit
        // colour), summed into the normal equations in pixel order: the same bits
        // whatever the thread count.
        let bases: Vec<[[f64; 3]; 3]> = (0..self.pixels())
            .into_par_iter()
            .with_min_len(16)
            .map(|p| {
                let range = self.offsets[p]..self.offsets[p + 1];
                let mut basis = [[0.0f64; 3]; 3];
                for s in range.clone() {
                    for (b, w) in basis.iter_mut().zip(self.weights[s]) {
                        b[0] += FRAC_1_PI * w;
                    }
                }
                let mut buf = vec![[0.0; 3]; range.len()];
                for (k, l) in lobes.iter().enumerate() {
                    l.eval_f64_many(&self.pairs[range.clone()], &mut buf);
                    for (v, s) in buf.iter().zip(range.clone()) {
                        for c in 0..3 {
                            if v[c].is_finite() {
                                basis[c][k + 1] += v[c] * self.weights[s][c];
                            }
                        }
                    }
                }
                basis
            })
            .collect();
        let mut grams = [Gram::new(n), Gram::new(n), Gram::new(n)];
        for (basis, reference) in bases.iter().zip(&self.reference) {
            for c in 0..3 {
                grams[c].add(&basis[c][..n], reference[c], 1.0);
            }
        }
        let mut res = 0.0;
        let mut colours = [[0.0f64; 3]; 3];
        for (c, g) in grams.iter().enumerate() {
            let (xs, r) = g.solve_nonnegative();
            res += r;
            for k in 0..3 {
                colours[k][c] = xs[k];
            }
        }
        ((res / (3.0 * self.pixels().max(1) as f64)).sqrt(), colours)
    }
}

/// The samples of the pixel of normal `n` (index `p`, seeding its sample rotations) under
/// `env`, `n_env` from the map and `n_cone` around the mirror direction; samples below the
/// surface or of zero weight are dropped.
fn pixel_samples(
    env: &dyn Environment,
    n: DVec3,
    p: u64,
    (n_env, n_cone): (usize, usize),
) -> Vec<WeightedPair> {
    let view = DVec3::Z;
    let mirror = (2.0 * n.dot(view) * n - view).normalize();
    let frame = Frame::from_normal(n.as_vec3());
    let local = |d: DVec3| frame.to_local(d.as_vec3()).as_dvec3();
    let wo = local(view);
    let rot = |salt: u64| [unit(hash(p, salt)), unit(hash(p, salt + 1))];
    let (rot_env, rot_cone) = (rot(1), rot(3));
    let mut out = Vec::with_capacity(n_env + n_cone);
    let mut push = |d: DVec3, radiance: [f64; 3], p_env: f64| {
        let cos = n.dot(d);
        let density = n_env as f64 * p_env + n_cone as f64 * mirror_cones::pdf(mirror, d);
        if cos > 0.0 && density > 0.0 && radiance.iter().any(|&l| l > 0.0) {
            out.push(((wo, local(d)), radiance.map(|l| l.max(0.0) * cos / density)));
        }
    };
    for k in 0..n_env {
        if let Some((d, radiance, p_env)) = env.sample(hammersley(k, n_env, rot_env)) {
            push(d.as_dvec3().normalize(), radiance, p_env);
        }
    }
    for k in 0..n_cone {
        let [u, v] = hammersley(k, n_cone, rot_cone);
        let e = mirror_cones::EXPONENTS[k % mirror_cones::EXPONENTS.len()];
        let d = mirror_cones::sample(mirror, e, [u, v]);
        let (radiance, p_env) = env.eval_pdf(d.as_vec3());
        push(d, radiance, p_env);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A constant environment of radiance 1, sampled uniformly over the sphere.
    struct Uniform;

    impl Environment for Uniform {
        fn sample(&self, u: [f64; 2]) -> Option<(Vec3, [f64; 3], f64)> {
            let z = 1.0 - 2.0 * u[0];
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * u[1];
            let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            Some((d, [1.0; 3], 1.0 / (4.0 * PI)))
        }
        fn eval_pdf(&self, _: Vec3) -> ([f64; 3], f64) {
            ([1.0; 3], 1.0 / (4.0 * PI))
        }
    }

    #[test]
    fn a_white_lambertian_sphere_under_a_white_sky_has_radiance_one() {
        // int (1/pi) cos dwi over the hemisphere = 1 at every pixel (furnace test).
        let im = SphereImages::new(
            &[&Uniform],
            ImageSettings {
                resolution: 8,
                samples: 256,
            },
        );
        let img = im.render(&|_, _| [FRAC_1_PI; 3]);
        let mean = img.iter().map(|p| p[0]).sum::<f64>() / img.len() as f64;
        assert!((mean - 1.0).abs() < 0.02, "{mean}");
        assert!(img.iter().all(|p| (p[1] - 1.0).abs() < 0.15), "{img:?}");
    }
}
