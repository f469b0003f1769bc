//! MERL isotropic BRDF tables (Matusik, Pfister, Brand and McMillan, "A Data-Driven
//! Reflectance Model", SIGGRAPH 2003), the `.binary` format: three little-endian int32
//! dimensions (90, 90, 180: theta_h, theta_d, phi_d), then 3 x N little-endian doubles
//! (all red, then green, then blue), N = 90 x 90 x 180.
//!
//! A sample's index uses Rusinkiewicz's half/difference angles ([`crate::frame::half_diff`]):
//! theta_h is stored non-linearly, index floor(90 sqrt(theta_h / (pi/2))); theta_d linearly,
//! floor(90 theta_d / (pi/2)); phi_d over [0, pi) only (phi_d and phi_d + pi are the same
//! by reciprocity and isotropy), floor(180 phi_d / pi). Values are scaled by 1/1500,
//! 1.15/1500 and 1.66/1500 for red, green and blue; negative values are missing samples
//! (the measurement had none, e.g. within 3 degrees of retro-reflection).
//!
//! In memory the table is f32 RGB (17.5 MB). Lookups are nearest (the bin) or trilinear
//! between bin centres (periodic in phi_d), skipping missing corners.

use crate::Rgb;
use crate::error::FileError;
use crate::frame::{from_half_diff, half_diff};
use glam::Vec3;
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

pub const RES_THETA_H: usize = 90;
pub const RES_THETA_D: usize = 90;
pub const RES_PHI_D: usize = 180;
pub const SAMPLES: usize = RES_THETA_H * RES_THETA_D * RES_PHI_D;
/// Channel scale factors from stored values to BRDF values (1/sr).
pub const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// A MERL table, in BRDF units; a missing sample is negative.
#[derive(Clone)]
pub struct Merl {
    data: Vec<[f32; 3]>,
}

impl std::fmt::Debug for Merl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Merl[{} samples]", self.data.len())
    }
}

#[inline]
fn index(ith: usize, itd: usize, ipd: usize) -> usize {
    ipd + RES_PHI_D * (itd + RES_THETA_D * ith)
}

/// Continuous bin coordinates of half/difference angles (bin k spans [k, k + 1)).
#[inline]
fn coords(theta_h: f64, theta_d: f64, phi_d: f64) -> (f64, f64, f64) {
    let th = (theta_h.max(0.0) / FRAC_PI_2).sqrt() * RES_THETA_H as f64;
    let td = theta_d.max(0.0) / FRAC_PI_2 * RES_THETA_D as f64;
    let mut pd = phi_d;
    if pd < 0.0 {
        pd += PI;
    }
    let pd = (pd / PI * RES_PHI_D as f64).rem_euclid(RES_PHI_D as f64);
    (th, td, pd)
}

impl Merl {
    /// Reads a `.binary` file, checking its dimensions and length.
    pub fn memory_bytes(&self) -> usize {
        self.data.len() * 12
    }

    pub fn read(path: &Path) -> Result<Self, FileError> {
        let shown = path.display().to_string();
        if path.is_dir() {
            return Err(FileError::new(
                &shown,
                "is a directory; expected a MERL .binary file",
            ));
        }
        let bytes =
            std::fs::read(path).map_err(|e| FileError::new(&shown, format!("cannot read: {e}")))?;
        Self::from_bytes(&bytes, &shown)
    }

    pub fn from_bytes(bytes: &[u8], name: &str) -> Result<Self, FileError> {
        if bytes.len() < 12 {
            return Err(FileError::new(
                name,
                format!(
                    "{} bytes; expected a 12-byte header of three int32 dimensions and then data",
                    bytes.len()
                ),
            ));
        }
        let dim =
            |k: usize| i32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().expect("4 bytes"));
        let dims = [dim(0), dim(1), dim(2)];
        if dims != [RES_THETA_H as i32, RES_THETA_D as i32, RES_PHI_D as i32] {
            return Err(FileError::new(
                name,
                format!(
                    "dimensions {dims:?}; expected [90, 90, 180] (theta_h, theta_d, phi_d) of an isotropic MERL table"
                ),
            ));
        }
        let expected = 12 + 3 * SAMPLES * 8;
        if bytes.len() != expected {
            return Err(FileError::new(
                name,
                format!(
                    "{} bytes; expected {expected} (header + 3 x {SAMPLES} doubles): the file is {}",
                    bytes.len(),
                    if bytes.len() < expected {
                        "truncated"
                    } else {
                        "too long"
                    }
                ),
            ));
        }
        let mut data = vec![[0.0f32; 3]; SAMPLES];
        for c in 0..3 {
            let base = 12 + c * SAMPLES * 8;
            for (i, d) in data.iter_mut().enumerate() {
                let o = base + 8 * i;
                let v = f64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
                // The scaled value must be a BRDF f32 holds with room to spare.
                if !v.is_finite() || v * SCALE[c] > super::MAX_VALUE {
                    let (ith, itd, ipd) = (
                        i / (RES_THETA_D * RES_PHI_D),
                        (i / RES_PHI_D) % RES_THETA_D,
                        i % RES_PHI_D,
                    );
                    return Err(FileError::new(
                        name,
                        format!(
                            "sample {i} (theta_h bin {ith}, theta_d bin {itd}, phi_d bin {ipd}) of channel {c} is {v}, {:e} 1/sr after the channel scale; expected a finite value up to {:e} 1/sr (negative for missing)",
                            v * SCALE[c],
                            super::MAX_VALUE
                        ),
                    ));
                }
                d[c] = if v < 0.0 { -1.0 } else { (v * SCALE[c]) as f32 };
            }
        }
        Ok(Self { data })
    }

    /// The file bytes of this table (values divided by the channel scales).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(12 + 3 * SAMPLES * 8);
        for d in [RES_THETA_H, RES_THETA_D, RES_PHI_D] {
            out.extend_from_slice(&(d as i32).to_le_bytes());
        }
        for c in 0..3 {
            for d in &self.data {
                let v = if d[c] < 0.0 {
                    -1.0
                } else {
                    d[c] as f64 / SCALE[c]
                };
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    /// Writes a `.binary` file atomically.
    pub fn write(&self, path: &Path) -> Result<(), FileError> {
        let bytes = self.to_bytes();
        crate::io::atomic_write(path, |w| std::io::Write::write_all(w, &bytes))
    }

    /// Tabulates `f(wi, wo)` (RGB, 1/sr) at every bin centre (phi_h = 0); `None` marks a
    /// missing sample.
    pub fn from_fn(
        f: impl Fn(Vec3, Vec3, (usize, usize, usize)) -> Option<[f64; 3]> + Sync,
    ) -> Self {
        let mut data = vec![[0.0f32; 3]; SAMPLES];
        for ith in 0..RES_THETA_H {
            let u = (ith as f64 + 0.5) / RES_THETA_H as f64;
            let theta_h = u * u * FRAC_PI_2;
            for itd in 0..RES_THETA_D {
                let theta_d = (itd as f64 + 0.5) / RES_THETA_D as f64 * FRAC_PI_2;
                for ipd in 0..RES_PHI_D {
                    let phi_d = (ipd as f64 + 0.5) / RES_PHI_D as f64 * PI;
                    let (wi, wo) = from_half_diff(theta_h, 0.0, theta_d, phi_d);
                    data[index(ith, itd, ipd)] = match f(wi, wo, (ith, itd, ipd)) {
                        Some(v) => [
                            v[0].max(0.0) as f32,
                            v[1].max(0.0) as f32,
                            v[2].max(0.0) as f32,
                        ],
                        None => [-1.0; 3],
                    };
                }
            }
        }
        Self { data }
    }

    /// Stored value of a bin (negative: missing).
    pub fn bin(&self, ith: usize, itd: usize, ipd: usize) -> [f32; 3] {
        self.data[index(ith, itd, ipd)]
    }

    /// Nearest-bin value, or None below the surface or for a missing sample.
    pub fn measured(&self, wi: Vec3, wo: Vec3) -> Option<Rgb> {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return None;
        }
        let (th, _, td, pd) = half_diff(wi, wo);
        let (a, b, c) = coords(th, td, pd);
        let v = self.data[index(
            (a as usize).min(RES_THETA_H - 1),
            (b as usize).min(RES_THETA_D - 1),
            (c as usize).min(RES_PHI_D - 1),
        )];
        (v[0] >= 0.0).then(|| Rgb::from(v))
    }

    /// Nearest-bin lookup; zero below the surface or for a missing sample.
    pub fn lookup_nearest(&self, wi: Vec3, wo: Vec3) -> Rgb {
        self.measured(wi, wo).unwrap_or(Rgb::ZERO)
    }

    /// Trilinear lookup between bin centres (clamped in theta, periodic in phi_d),
    /// renormalized over the corners that are not missing.
    pub fn lookup(&self, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let (th, _, td, pd) = half_diff(wi, wo);
        let (a, b, c) = coords(th, td, pd);
        let split = |x: f64, n: usize| {
            let x = (x - 0.5).clamp(0.0, (n - 1) as f64);
            let i = (x as usize).min(n - 1);
            (i, (i + 1).min(n - 1), x - i as f64)
        };
        let (a0, a1, wa) = split(a, RES_THETA_H);
        let (b0, b1, wb) = split(b, RES_THETA_D);
        let xc = c - 0.5;
        let c0f = xc.floor();
        let wc = xc - c0f;
        let c0 = (c0f as i64).rem_euclid(RES_PHI_D as i64) as usize;
        let c1 = (c0 + 1) % RES_PHI_D;
        let mut acc = [0.0f64; 3];
        let mut wsum = 0.0;
        for (ia, fa) in [(a0, 1.0 - wa), (a1, wa)] {
            for (ib, fb) in [(b0, 1.0 - wb), (b1, wb)] {
                for (ic, fc) in [(c0, 1.0 - wc), (c1, wc)] {
                    let w = fa * fb * fc;
                    if w <= 0.0 {
                        continue;
                    }
                    let v = self.data[index(ia, ib, ic)];
                    if v[0] < 0.0 {
                        continue;
                    }
                    for k in 0..3 {
                        acc[k] += w * v[k] as f64;
                    }
                    wsum += w;
                }
            }
        }
        if wsum <= 0.0 {
            return Rgb::ZERO;
        }
        Rgb::new(
            (acc[0] / wsum) as f32,
            (acc[1] / wsum) as f32,
            (acc[2] / wsum) as f32,
        )
    }

    /// Fraction of bins that hold a sample.
    pub fn coverage(&self) -> f64 {
        self.data.iter().filter(|v| v[0] >= 0.0).count() as f64 / SAMPLES as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bin_centres_round_trip_through_the_index() {
        for &(ith, itd, ipd) in &[(0, 0, 0), (10, 45, 90), (89, 89, 179), (37, 3, 121)] {
            let u = (ith as f64 + 0.5) / 90.0;
            let (wi, wo) = from_half_diff(
                u * u * FRAC_PI_2,
                0.0,
                (itd as f64 + 0.5) / 90.0 * FRAC_PI_2,
                (ipd as f64 + 0.5) / 180.0 * PI,
            );
            let (th, _, td, pd) = half_diff(wi, wo);
            let (a, b, c) = coords(th, td, pd);
            assert_eq!(((a as usize), (b as usize), (c as usize)), (ith, itd, ipd));
        }
    }
}
