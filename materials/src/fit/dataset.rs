//! Data preparation for fitting (Ngan et al. 2005, sections 2.4 and 3.3): measured values in
//! bins of (theta_i, theta_o, phi_d) (1 degree by default) for isotropic data, or the
//! binned 4D data as they are for anisotropic data; empty bins skipped; bins with theta_i or
//! theta_o above 80 degrees dropped; each bin weighted by its solid-angle correction
//! w = sin(theta_i) sin(theta_o) (the bins are uniform in angle).

use crate::Rgb;
use crate::error::FileError;
use crate::measured::binned::Binned;
use crate::measured::format::{self, Format};
use crate::measured::merl::Merl;
use crate::measured::rgl::Rgl;
use glam::Vec3;

/// One bin: directions at its centre, measured RGB, weight.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub wi: Vec3,
    pub wo: Vec3,
    pub value: [f64; 3],
    pub weight: f64,
    /// cos(theta_i)^2, the metric's cosine factor squared.
    pub cos2: f64,
}

/// The data a model is fitted to.
#[derive(Clone, Debug)]
pub struct Dataset {
    pub samples: Vec<Sample>,
    pub anisotropic: bool,
    /// Largest directional albedo (over RGB and incidence 0 to 80 degrees) of the data,
    /// which normalizes the reported errors (section 4.1).
    pub max_albedo: f64,
}

/// Largest angle kept (degrees).
pub const CUTOFF_DEG: f64 = 80.0;

/// The unit direction at (theta, phi) in degrees (local frame, z the normal).
pub fn dir(theta_deg: f64, phi_deg: f64) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
}

impl Dataset {
    /// Isotropic data from a function returning the measured value of (wi, wo) or None for
    /// a missing sample, on bins of `res_deg` degrees.
    pub fn isotropic(f: &(dyn Fn(Vec3, Vec3) -> Option<Rgb> + Sync), res_deg: f64) -> Self {
        use rayon::prelude::*;
        let nt = (CUTOFF_DEG / res_deg).round() as usize;
        let np = (180.0 / res_deg).round() as usize;
        let samples: Vec<Sample> = (0..nt * nt)
            .into_par_iter()
            .flat_map_iter(|k| {
                let (a, b) = (k / nt, k % nt);
                let ti = (a as f64 + 0.5) * res_deg;
                let to = (b as f64 + 0.5) * res_deg;
                (0..np).filter_map(move |c| {
                    let pd = (c as f64 + 0.5) * res_deg;
                    let (wi, wo) = (dir(ti, 0.0), dir(to, pd));
                    // Non-finite values are kept so that `check` reports them.
                    let v = f(wi, wo)?;
                    let ci = ti.to_radians().cos();
                    Some(Sample {
                        wi,
                        wo,
                        value: [v.r as f64, v.g as f64, v.b as f64],
                        weight: ti.to_radians().sin() * to.to_radians().sin(),
                        cos2: ci * ci,
                    })
                })
            })
            .collect();
        let max_albedo = Self::albedo_of(f);
        Self {
            samples,
            anisotropic: false,
            max_albedo,
        }
    }

    /// From a measured file of any format (told by its content, see
    /// [`crate::measured::format`]); isotropic tables are binned at `res_deg`.
    pub fn read(path: &std::path::Path, res_deg: f64) -> Result<Self, FileError> {
        if !path.exists() {
            return Err(FileError::new(
                path.display(),
                "does not exist; expected a measured BRDF file (MERL, binned or RGL)",
            ));
        }
        Ok(match format::detect(path)? {
            Format::Merl => Self::from_merl(&Merl::read(path)?, res_deg),
            Format::Binned => Self::from_binned(&Binned::read(path)?),
            Format::Rgl => {
                let t = Rgl::read(path)?;
                Self::isotropic(&|wi, wo| Some(t.eval(wo, wi)), res_deg)
            }
        })
    }

    /// From a MERL table (missing samples skipped).
    pub fn from_merl(t: &Merl, res_deg: f64) -> Self {
        Self::isotropic(&|wi, wo| t.measured(wi, wo), res_deg)
    }

    /// From binned data: every non-empty bin below the cut-off.
    pub fn from_binned(t: &Binned) -> Self {
        let mut samples = Vec::new();
        for (k, v) in t.values.iter().enumerate() {
            let Some(v) = v else { continue };
            let (wi, wo) = t.directions(k);
            let (ti, to) = (
                (wi.z as f64).acos().to_degrees(),
                (wo.z as f64).acos().to_degrees(),
            );
            if ti > CUTOFF_DEG || to > CUTOFF_DEG {
                continue;
            }
            let ci = wi.z as f64;
            samples.push(Sample {
                wi,
                wo,
                value: [v[0] as f64, v[1] as f64, v[2] as f64],
                weight: ti.to_radians().sin() * to.to_radians().sin(),
                cos2: ci * ci,
            });
        }
        let filled = t.filled_copy();
        let max_albedo = Self::albedo_of(&|wi, wo| Some(filled.lookup(wi, wo)));
        Self {
            samples,
            anisotropic: t.anisotropic,
            max_albedo,
        }
    }

    /// Largest directional albedo int f cos(theta_o) dwo over incidence 0..80 degrees and
    /// the RGB channels (midpoint rule, 1 x 2 degree cells).
    pub fn albedo_of(f: &(dyn Fn(Vec3, Vec3) -> Option<Rgb> + Sync)) -> f64 {
        use rayon::prelude::*;
        (0..=8)
            .into_par_iter()
            .map(|k| {
                let wi = dir(10.0 * k as f64, 0.0);
                let mut acc = [0.0f64; 3];
                for a in 0..90 {
                    let to = a as f64 + 0.5;
                    let d = (to.to_radians().sin() * to.to_radians().cos())
                        * (1f64.to_radians())
                        * (2f64.to_radians());
                    for b in 0..180 {
                        let v = f(wi, dir(to, b as f64 * 2.0 + 1.0)).unwrap_or(Rgb::ZERO);
                        for (c, x) in v.to_array().into_iter().enumerate() {
                            acc[c] += x.max(0.0) as f64 * d;
                        }
                    }
                }
                acc[0].max(acc[1]).max(acc[2])
            })
            .reduce(|| 0.0, f64::max)
    }

    /// Can these data be fitted? At least one bin, every value finite.
    pub fn check(&self) -> Result<(), String> {
        if self.samples.is_empty() {
            return Err(format!(
                "no measured values with theta_i and theta_o at most {CUTOFF_DEG} degrees \
                 (every bin is empty or past the cut-off); expected at least one"
            ));
        }
        if let Some(s) = self
            .samples
            .iter()
            .find(|s| !s.value.iter().all(|v| v.is_finite()))
        {
            return Err(format!(
                "the value at theta_i = {:.2}, theta_o = {:.2} degrees is {:?}; expected finite values",
                (s.wi.z as f64).acos().to_degrees(),
                (s.wo.z as f64).acos().to_degrees(),
                s.value
            ));
        }
        if self
            .samples
            .iter()
            .all(|s| s.value.iter().all(|&v| v == 0.0))
        {
            return Err(format!(
                "every one of the {} measured values is zero; expected a material that reflects light",
                self.samples.len()
            ));
        }
        Ok(())
    }

    pub fn total_weight(&self) -> f64 {
        self.samples.iter().map(|s| s.weight).sum()
    }

    /// A subset of about `target` samples that stands in for the whole in the Eq. (1) sums:
    /// the samples of largest cosine-weighted value (the specular peak, which a uniform
    /// subsample would miss for a sharp material) kept as they are, one in every `stride` of
    /// the others with its weight multiplied by `stride`. Deterministic. Returns a clone
    /// when the data are already small.
    pub fn coarse(&self, target: usize) -> Dataset {
        let n = self.samples.len();
        if n <= 2 * target.max(1) {
            return self.clone();
        }
        let key = |s: &Sample| s.value.iter().cloned().fold(0.0f64, f64::max) * s.cos2.sqrt();
        let peak = (target / 4).max(1);
        let mut keys: Vec<f64> = self.samples.iter().map(key).collect();
        let (_, &mut threshold, _) = keys.select_nth_unstable_by(n - peak, f64::total_cmp);
        let rest = (n - peak).max(1);
        let stride = rest.div_ceil((target - peak).max(1)).max(1);
        let mut others = 0usize;
        let mut samples = Vec::with_capacity(target + peak);
        for s in &self.samples {
            if key(s) >= threshold {
                samples.push(*s);
            } else {
                if others.is_multiple_of(stride) {
                    samples.push(Sample {
                        weight: s.weight * stride as f64,
                        ..*s
                    });
                }
                others += 1;
            }
        }
        Dataset {
            samples,
            anisotropic: self.anisotropic,
            max_albedo: self.max_albedo,
        }
    }
}
