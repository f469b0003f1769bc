//! Closed-form and synthetic distributions of normals for the microfacet generator
//! (anisotropic Beckmann, and the brushed-metal, satin and velvet structures of Ngan et
//! al. 2005, section 5.1), and sparse anisotropic 4D measurements of a BRDF sampled as
//! the study sampled its anisotropic materials, from which the tests estimate them back.

use crate::Rgb;
use crate::fit::dataset::Dataset;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// Closed-form or synthetic distributions of normals (unnormalized densities over the
/// hemisphere with respect to solid angle).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Anisotropic Beckmann: exp(-(hx^2/ax^2 + hy^2/ay^2)/hz^2) / (pi ax ay hz^4).
    Beckmann { alpha_x: f64, alpha_y: f64 },
    /// Brushed metal: a ridge of angular width `width` (radians) along the great circle
    /// through the normal perpendicular to x (the brushing direction is y), fading with
    /// angle from the normal over `falloff` radians.
    Brushed { width: f64, falloff: f64 },
    /// Satin: two such ridges along great circles tilted by +-`tilt` from the vertical.
    Satin { width: f64, tilt: f64, falloff: f64 },
    /// Velvet: a main lobe around the normal of width `main` plus a secondary ring at
    /// `ring` radians from the normal, of width `ring_width` and relative weight `weight`.
    Velvet {
        main: f64,
        ring: f64,
        ring_width: f64,
        weight: f64,
    },
}

impl Shape {
    /// The three structures of section 5.1 as used by the tests and `lobe microfacet synth`.
    pub fn synthetic(name: &str) -> Option<Shape> {
        let deg = |d: f64| d.to_radians();
        Some(match name {
            "brushed" => Shape::Brushed {
                width: deg(3.0),
                falloff: deg(35.0),
            },
            "satin" => Shape::Satin {
                width: deg(5.0),
                tilt: deg(25.0),
                falloff: deg(45.0),
            },
            "velvet" => Shape::Velvet {
                main: deg(12.0),
                ring: deg(62.0),
                ring_width: deg(8.0),
                weight: 0.25,
            },
            _ => return None,
        })
    }

    pub fn density(&self, h: DVec3) -> f64 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let theta = h.z.clamp(-1.0, 1.0).acos();
        let ridge = |axis: DVec3, width: f64| {
            let off = h.dot(axis).clamp(-1.0, 1.0).asin();
            (-(off / width).powi(2)).exp()
        };
        match *self {
            Shape::Beckmann { alpha_x, alpha_y } => {
                let e = (h.x * h.x / (alpha_x * alpha_x) + h.y * h.y / (alpha_y * alpha_y))
                    / (h.z * h.z);
                (-e).exp() / (PI * alpha_x * alpha_y * h.z.powi(4))
            }
            Shape::Brushed { width, falloff } => {
                ridge(DVec3::X, width) * (-(theta / falloff).powi(2)).exp()
            }
            Shape::Satin {
                width,
                tilt,
                falloff,
            } => {
                let (s, c) = tilt.sin_cos();
                (ridge(DVec3::new(c, 0.0, s), width) + ridge(DVec3::new(c, 0.0, -s), width))
                    * (-(theta / falloff).powi(2)).exp()
            }
            Shape::Velvet {
                main,
                ring,
                ring_width,
                weight,
            } => {
                (-(theta / main).powi(2)).exp()
                    + weight * (-((theta - ring) / ring_width).powi(2)).exp()
            }
        }
    }
}

/// Sparse anisotropic 4D data of `f(wi, wo)` (per channel, no cosine) as the study sampled
/// its anisotropic measurements: bins of `res_deg` in (theta_i, theta_o, phi_i, phi_o), a
/// fraction `filled` of them non-empty (chosen by a hash of the bin and `seed`), nothing
/// past 80 degrees, each bin weighted by sin(theta_i) sin(theta_o).
pub fn sparse_4d(
    f: &(dyn Fn(Vec3, Vec3) -> [f64; 3] + Sync),
    res_deg: f64,
    filled: f64,
    seed: u64,
) -> Dataset {
    use crate::fit::dataset::{CUTOFF_DEG, Sample};
    use crate::measured::tabulate::Acquisition;
    use rayon::prelude::*;
    let acq = Acquisition {
        empty_fraction: 1.0 - filled,
        seed,
        ..Default::default()
    };
    let nt = (CUTOFF_DEG / res_deg).floor() as usize;
    let np = (360.0 / res_deg).round() as usize;
    use crate::fit::dataset::dir;
    let samples: Vec<Sample> = (0..nt * nt * np)
        .into_par_iter()
        .flat_map_iter(|k| {
            let (ti, to, pi) = (k / (nt * np), (k / np) % nt, k % np);
            let (ti, to, pi) = (
                (ti as f64 + 0.5) * res_deg,
                (to as f64 + 0.5) * res_deg,
                (pi as f64 + 0.5) * res_deg,
            );
            let wi = dir(ti, pi);
            let ci = ti.to_radians().cos();
            let w = ti.to_radians().sin() * to.to_radians().sin();
            (0..np).filter_map(move |po| {
                if acq.bin_empty((k * np + po) as u64) {
                    return None;
                }
                let wo = dir(to, (po as f64 + 0.5) * res_deg);
                Some(Sample {
                    wi,
                    wo,
                    value: f(wi, wo),
                    weight: w,
                    cos2: ci * ci,
                })
            })
        })
        .collect();
    let max_albedo = Dataset::albedo_of(&|wi, wo| {
        let v = f(wi, wo);
        Some(Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32))
    });
    Dataset {
        samples,
        anisotropic: true,
        max_albedo,
    }
}
