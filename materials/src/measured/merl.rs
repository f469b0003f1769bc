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
//! between bin centres (periodic in phi_d), skipping missing corners. Both lookups the
//! renderer uses run in f32 without trigonometric rotations ([`bin_coords`]), one pair at a
//! time or `LANES` ([`Merl::interpolate`], [`Merl::nearest`]: the batched evaluation of the
//! `merl` material); fitting ([`Merl::measured`]) keeps the f64 angles of [`half_diff`].

use crate::Rgb;
use crate::error::FileError;
use crate::frame::{from_half_diff, half_diff};
use crate::math::{Num, V3, atan2, clamp, floor, gt, le, lt, maximum, select, sqrt};
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

/// Continuous bin coordinates `[theta_h, theta_d, phi_d]` of a direction pair above the
/// surface (one pair, or lanes of pairs): Rusinkiewicz's half/difference angles as
/// [`half_diff`] computes them, with the two rotations taken from the half vector's own
/// components (cos and sin of theta_h and phi_h are h.z, |h.xy| and h.xy / |h.xy|: no
/// trigonometric call) and every angle an `atan2` of a sine and a cosine
/// ([`crate::fastmath::atan2`] in f32), which stays accurate near 0 where `acos` loses half the
/// digits (theta_h's bins are finest there).
#[inline(always)]
pub fn bin_coords<T: Num>(wi: V3<T>, wo: V3<T>) -> [T; 3] {
    let (zero, one) = (T::of(0.0), T::of(1.0));
    let origin = V3::new(zero, zero, zero);
    let (wi, wo) = (wi.unit_or(origin), wo.unit_or(origin));
    let h = (wi + wo).unit_or(V3::new(zero, zero, one));
    let sin_h = sqrt(h.x * h.x + h.y * h.y);
    let theta_h = atan2(sin_h, h.z);
    let has_phi = gt(sin_h, zero);
    let (cp, sp) = (
        select(has_phi, h.x / sin_h, one),
        select(has_phi, h.y / sin_h, zero),
    );
    // wi rotated by -phi_h about z, then by -theta_h about y.
    let t = V3::new(wi.x * cp + wi.y * sp, wi.y * cp - wi.x * sp, wi.z);
    let d = V3::new(t.x * h.z - t.z * sin_h, t.y, t.x * sin_h + t.z * h.z);
    let theta_d = atan2(sqrt(d.x * d.x + d.y * d.y), d.z);
    let phi_d = atan2(d.y, d.x);
    let pi = T::of(PI);
    let phi_d = select(lt(phi_d, zero), phi_d + pi, phi_d);
    let n_pd = T::of(RES_PHI_D as f64);
    let pd = phi_d / pi * n_pd;
    let quarter = T::of(FRAC_PI_2);
    [
        sqrt(maximum(theta_h, zero) / quarter) * T::of(RES_THETA_H as f64),
        maximum(theta_d, zero) / quarter * T::of(RES_THETA_D as f64),
        select(le(n_pd, pd), pd - n_pd, pd),
    ]
}

/// The two bins either side of a clamped continuous coordinate and the second's weight:
/// `(i0, i1, w)` with `x - 0.5` clamped to [0, n - 1] (bin centres at k + 1/2).
#[inline(always)]
fn split_clamped<T: Num>(x: T, n: usize) -> (T::Int, T::Int, T) {
    let x = clamp(x - T::of(0.5), T::of(0.0), T::of((n - 1) as f64));
    let i = floor(x);
    let i0 = i.trunc_int();
    (i0, T::int_min(i0 + T::int(1), T::int(n as i32 - 1)), x - i)
}

/// The two bins either side of the periodic phi_d coordinate and the second's weight.
#[inline(always)]
fn split_periodic<T: Num>(x: T) -> (T::Int, T::Int, T) {
    let xc = x - T::of(0.5);
    let f = floor(xc);
    let i = f.trunc_int();
    let n = T::int(RES_PHI_D as i32);
    let i0 = T::int_select(T::int_lt(i, T::int(0)), i + n, i);
    let i1 = i0 + T::int(1);
    let i1 = T::int_select(T::int_eq(i1, n), T::int(0), i1);
    (i0, i1, xc - f)
}

impl Merl {
    /// Reads a `.binary` file, checking its dimensions and length.
    pub fn memory_bytes(&self) -> usize {
        self.data.len() * 12
    }

    pub fn read(path: &Path) -> Result<Self, FileError> {
        let shown = path.display().to_string();
        // A MERL file has one size: nothing far beyond it is read (a little more is, so
        // that a slightly long file is told its exact expected length).
        let size = (12 + 3 * SAMPLES * 8) as u64;
        let bytes = crate::io::read_regular(path, 2 * size, "a MERL .binary file")?;
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

    /// Nearest-bin lookup; zero below the surface or for a missing sample
    /// ([`Merl::nearest`] of one pair).
    pub fn lookup_nearest(&self, wi: Vec3, wo: Vec3) -> Rgb {
        Rgb::from(self.nearest::<f32>(wi.into(), wo.into()))
    }

    /// The value of the bin that holds the pair (bin k spans [k, k + 1) of
    /// [`bin_coords`], the coordinates [`Merl::interpolate`] uses), written once over [`Num`]
    /// (one pair, or lanes of pairs): zero below the surface or for a missing sample.
    #[inline]
    pub fn nearest<T: Num>(&self, wi: V3<T>, wo: V3<T>) -> [T; 3] {
        let s = T::of;
        let above = gt(wi.z, s(0.0)) & gt(wo.z, s(0.0));
        let [a, b, c] = bin_coords(wi, wo);
        // Clamped (NaN coordinates to bin 0), so every index is inside the table.
        let bin = |x: T, n: usize| clamp(floor(x), s(0.0), s((n - 1) as f64)).trunc_int();
        let row = bin(a, RES_THETA_H) * T::int(RES_THETA_D as i32) + bin(b, RES_THETA_D);
        let at = (row * T::int(RES_PHI_D as i32) + bin(c, RES_PHI_D)) * T::int(3);
        let flat = self.data.as_flattened();
        let v = [0, 1, 2].map(|k| T::gather(flat, at + T::int(k)));
        let keep = above & le(s(0.0), v[0]);
        v.map(|x| select(keep, x, s(0.0)))
    }

    /// Trilinear lookup between bin centres (clamped in theta, periodic in phi_d),
    /// renormalized over the corners that are not missing, in f32 throughout: the bin
    /// coordinates from [`bin_coords`], the corners' weights and sums in f32
    /// ([`Merl::interpolate`], which the renderer calls for one pair and for lanes).
    pub fn lookup(&self, wi: Vec3, wo: Vec3) -> Rgb {
        if !(wi.z > 0.0 && wo.z > 0.0) {
            return Rgb::ZERO;
        }
        Rgb::from(self.interpolate::<f32>(wi.into(), wo.into()))
    }

    /// [`Merl::lookup`] written once over [`Num`] (one pair, or lanes of pairs): the
    /// coordinates and weights, the eight corners' values gathered, the missing ones and
    /// the pairs below the surface weighted zero.
    #[inline]
    pub fn interpolate<T: Num>(&self, wi: V3<T>, wo: V3<T>) -> [T; 3] {
        let s = T::of;
        let above = gt(wi.z, s(0.0)) & gt(wo.z, s(0.0));
        let [a, b, c] = bin_coords(wi, wo);
        let (a0, a1, wa) = split_clamped(a, RES_THETA_H);
        let (b0, b1, wb) = split_clamped(b, RES_THETA_D);
        let (c0, c1, wc) = split_periodic(c);
        let flat = self.data.as_flattened();
        let (mut r, mut g, mut bl, mut wsum) = (s(0.0), s(0.0), s(0.0), s(0.0));
        for (ia, fa) in [(a0, s(1.0) - wa), (a1, wa)] {
            for (ib, fb) in [(b0, s(1.0) - wb), (b1, wb)] {
                let row = (ia * T::int(RES_THETA_D as i32) + ib) * T::int(RES_PHI_D as i32);
                for (ic, fc) in [(c0, s(1.0) - wc), (c1, wc)] {
                    let w = fa * fb * fc;
                    let at = (row + ic) * T::int(3);
                    let vr = T::gather(flat, at);
                    let keep = above & gt(w, s(0.0)) & le(s(0.0), vr);
                    let w = select(keep, w, s(0.0));
                    r = r + vr * w;
                    g = g + T::gather(flat, at + T::int(1)) * w;
                    bl = bl + T::gather(flat, at + T::int(2)) * w;
                    wsum = wsum + w;
                }
            }
        }
        let some = gt(wsum, s(0.0));
        [r, g, bl].map(|x| select(some, x / wsum, s(0.0)))
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
            let [a, b, c] = bin_coords(V3::from(wi), V3::from(wo));
            assert_eq!(((a as usize), (b as usize), (c as usize)), (ith, itd, ipd));
        }
    }

    /// The nearest lookup reads the bin that holds the pair (each bin's value its index
    /// here), zero below the surface or where a bin is missing, and lanes read what one
    /// pair does, bit for bit (NaN and infinite directions included).
    #[test]
    fn the_nearest_bin_is_the_one_that_holds_the_pair() {
        use crate::simd::{LANES, Vec3xN};
        let mut data: Vec<[f32; 3]> = (0..SAMPLES).map(|i| [i as f32, 1.0, 2.0]).collect();
        data[index(37, 3, 121)] = [-1.0; 3];
        let t = Merl { data };
        for &(ith, itd, ipd) in &[(0, 0, 0), (10, 45, 90), (60, 20, 179), (37, 3, 121)] {
            let u = (ith as f64 + 0.5) / 90.0;
            let (wi, wo) = from_half_diff(
                u * u * FRAC_PI_2,
                0.3,
                (itd as f64 + 0.5) / 90.0 * FRAC_PI_2,
                (ipd as f64 + 0.5) / 180.0 * PI,
            );
            let want = match (ith, itd, ipd) {
                (37, 3, 121) => [0.0; 3],
                _ => [index(ith, itd, ipd) as f32, 1.0, 2.0],
            };
            let got = t.lookup_nearest(wi, wo).to_array();
            assert_eq!(got, want, "bin ({ith}, {itd}, {ipd})");
        }
        let below = t.lookup_nearest(Vec3::new(0.0, 0.6, -0.8), Vec3::Z);
        assert_eq!(below.to_array(), [0.0; 3]);
        let odd = [f32::NAN, f32::INFINITY, -0.0, 1e-30, -1.0];
        let pairs: Vec<(Vec3, Vec3)> = (0..4 * LANES)
            .map(|k| {
                let f = |m: usize| ((k * m + 3) % 97) as f32 / 48.0 - 1.0;
                let wi = Vec3::new(f(31), f(17), f(7).abs());
                let wo = Vec3::new(f(13), f(29), f(11));
                match k % 7 {
                    0 => (Vec3::new(odd[k % 5], 0.1, 0.5), wo),
                    1 => (wi, Vec3::new(0.2, odd[(k + 2) % 5], odd[k % 5])),
                    _ => (wi, wo),
                }
            })
            .collect();
        for chunk in pairs.chunks(LANES) {
            let lanes = |f: fn(&(Vec3, Vec3)) -> Vec3| {
                Vec3xN::from_array(&crate::simd::lanes(|k| f(&chunk[k])))
            };
            let v = t.nearest(lanes(|p| p.0), lanes(|p| p.1));
            for (k, (wi, wo)) in chunk.iter().enumerate() {
                let one = t.lookup_nearest(*wi, *wo).to_array();
                let got = v.map(|c| c.to_array()[k]);
                assert_eq!(got.map(f32::to_bits), one.map(f32::to_bits), "{wi} {wo}");
            }
        }
    }

    /// The renderer's f32 coordinates follow the f64 definition to a small fraction of a
    /// bin, including theta_h near 0 (where the sqrt spacing makes bins finest).
    #[test]
    fn f32_coordinates_follow_the_f64_ones() {
        let mut worst = [0.0f64; 3];
        for k in 0..20_000u32 {
            let f =
                |m: u32, s: u32| ((k.wrapping_mul(m).wrapping_add(s)) % 10_007) as f64 / 10_007.0;
            let th = f(7919, 1).powi(3) * FRAC_PI_2 * 0.999;
            // Up to 85 degrees: beyond, wi + wo cancels and the half vector itself is
            // ill-conditioned in the f32 inputs (both forms then differ by up to 1.5 bins).
            let td = f(104_729, 3) * 85f64.to_radians();
            let pd = (f(1_299_709, 5) - 0.5) * 2.0 * PI;
            let ph = (f(15_485_863, 7) - 0.5) * 2.0 * PI;
            let (wi, wo) = from_half_diff(th, ph, td, pd);
            if wi.z <= 1e-3 || wo.z <= 1e-3 {
                continue;
            }
            let (th, _, td, pd) = half_diff(wi, wo);
            let exact = coords(th, td, pd);
            let fast = bin_coords(V3::from(wi), V3::from(wo));
            // Below half a bin of theta_h every lookup takes bin 0 (the f32 half vector's
            // rounding, ~1e-7 rad, is 0.02-0.05 bins there through the sqrt); phi_d is
            // undefined where theta_h or theta_d vanishes.
            let dh = if exact.0 >= 0.5 {
                (fast[0] as f64 - exact.0).abs()
            } else {
                0.0
            };
            let mut dc = (fast[2] as f64 - exact.2).abs();
            dc = dc.min(RES_PHI_D as f64 - dc);
            if th < 1e-3 || td < 1e-3 {
                dc = 0.0;
            }
            for (w, e) in worst
                .iter_mut()
                .zip([dh, (fast[1] as f64 - exact.1).abs(), dc])
            {
                *w = w.max(e);
            }
        }
        assert!(
            worst.iter().all(|&e| e < 0.02),
            "largest differences in bins: {worst:?}"
        );
    }
}
