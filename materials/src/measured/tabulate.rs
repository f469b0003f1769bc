//! Tabulating any material as measured data, with options that emulate a real acquisition
//! (Ngan et al. 2005, sections 2.1-2.4): multiplicative Gaussian noise of a given relative
//! size, no samples within a given angle of retro-reflection (the light source hides the
//! detector: 3 degrees in the MERL data), none past a grazing cut-off, and a given fraction
//! of empty bins. Every random choice is a hash of (seed, bin, sub-sample), so the same
//! options give the same file whatever the thread count.

use super::binned::Binned;
use super::merl::Merl;
use crate::Rgb;
use glam::Vec3;
use rayon::prelude::*;

/// Acquisition emulation options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Acquisition {
    /// Relative standard deviation of multiplicative Gaussian noise (0: none).
    pub noise: f64,
    /// No samples within this angle (degrees) of the retro-reflection direction wi = wo.
    pub retro_exclusion_deg: f64,
    /// No samples with theta_i or theta_o above this angle (degrees).
    pub grazing_cutoff_deg: f64,
    /// Fraction of bins left empty at random.
    pub empty_fraction: f64,
    pub seed: u64,
}

impl Default for Acquisition {
    fn default() -> Self {
        Self {
            noise: 0.0,
            retro_exclusion_deg: 0.0,
            grazing_cutoff_deg: 90.0,
            empty_fraction: 0.0,
            seed: 0,
        }
    }
}

fn mix(mut x: u64) -> u64 {
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58476d1ce4e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d049bb133111eb);
    x ^ (x >> 31)
}

fn unit(h: u64) -> f64 {
    ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

impl Acquisition {
    fn hash(&self, a: u64, b: u64) -> u64 {
        mix(self.seed
            ^ mix(a.wrapping_mul(0x9e3779b97f4a7c15) ^ mix(b.wrapping_add(0x632be59bd9b4e019))))
    }

    /// Is bin `k` left empty?
    pub fn bin_empty(&self, k: u64) -> bool {
        self.empty_fraction > 0.0 && unit(self.hash(k, u64::MAX)) < self.empty_fraction
    }

    /// Can a sample be taken at this direction pair?
    pub fn measurable(&self, wi: Vec3, wo: Vec3) -> bool {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return false;
        }
        let cut = self.grazing_cutoff_deg.to_radians().cos() as f32;
        if wi.z < cut || wo.z < cut {
            return false;
        }
        let retro = (wi.dot(wo).clamp(-1.0, 1.0) as f64).acos().to_degrees();
        retro >= self.retro_exclusion_deg
    }

    /// Noise factor of sub-sample `s` of bin `k`.
    pub fn noise_factor(&self, k: u64, s: u64) -> f64 {
        if self.noise <= 0.0 {
            return 1.0;
        }
        let h = self.hash(k, s);
        let (u1, u2) = (unit(h), unit(mix(h)));
        let g = (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
        (1.0 + self.noise * g).max(0.0)
    }
}

/// A MERL table of `f(wo, wi)` at the bin centres, with acquisition emulation.
pub fn merl_from(f: &(dyn Fn(Vec3, Vec3) -> Rgb + Sync), acq: &Acquisition) -> Merl {
    Merl::from_fn(|wi, wo, (a, b, c)| {
        let k = ((a * 90 + b) * 180 + c) as u64;
        if !acq.measurable(wi, wo) || acq.bin_empty(k) {
            return None;
        }
        let v = f(wo, wi);
        let n = acq.noise_factor(k, 0);
        Some([v.r as f64 * n, v.g as f64 * n, v.b as f64 * n])
    })
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Binned data of `f(wo, wi)`: each bin the per-channel median of its measurable
/// sub-samples (a 2 x 2 x 2 grid for isotropic layouts, the centre for anisotropic ones),
/// with acquisition emulation.
pub fn binned_from(
    f: &(dyn Fn(Vec3, Vec3) -> Rgb + Sync),
    anisotropic: bool,
    acq: &Acquisition,
) -> Binned {
    let layout = if anisotropic {
        Binned::anisotropic_layout()
    } else {
        Binned::isotropic_layout()
    };
    let mut out = Binned::empty(anisotropic, layout);
    let axes = out.axes.clone();
    let shape = out.clone_shape();
    let values: Vec<Option<[f32; 3]>> = (0..out.len())
        .into_par_iter()
        .map(|k| {
            if acq.bin_empty(k as u64) {
                return None;
            }
            let bins = shape.unindex(k);
            let subs: Vec<Vec<f64>> = if anisotropic {
                vec![bins.iter().zip(&axes).map(|(&b, a)| a.centre(b)).collect()]
            } else {
                let mut v = Vec::with_capacity(8);
                for s in 0..8 {
                    v.push(
                        bins.iter()
                            .zip(&axes)
                            .enumerate()
                            .map(|(d, (&b, a))| {
                                a.min
                                    + (b as f64 + if (s >> d) & 1 == 1 { 0.75 } else { 0.25 })
                                        * a.width()
                            })
                            .collect(),
                    );
                }
                v
            };
            let mut ch: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
            for (s, ang) in subs.iter().enumerate() {
                let (wi, wo) = shape.directions_at(ang);
                if !acq.measurable(wi, wo) {
                    continue;
                }
                let v = f(wo, wi);
                let n = acq.noise_factor(k as u64, s as u64);
                for (c, x) in v.to_array().into_iter().enumerate() {
                    ch[c].push(x as f64 * n);
                }
            }
            if ch[0].is_empty() {
                return None;
            }
            Some([
                median(&mut ch[0]) as f32,
                median(&mut ch[1]) as f32,
                median(&mut ch[2]) as f32,
            ])
        })
        .collect();
    out.values = values;
    out
}
