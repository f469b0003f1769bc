//! The study's binned representation (Ngan et al. 2005, section 2.4): BRDF samples grouped
//! in bins uniform in (theta_i, theta_o, phi_d) for isotropic data (1 degree) or
//! (theta_i, theta_o, phi_i, phi_o) for anisotropic data (2 degrees), each bin holding the
//! median of its samples; bins may be empty (the study's data is about 85 % and 25 % full).
//!
//! File format (little-endian; docs/binned-format.md):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `LOBEBIN1` |
//! | 4 | u32 version, 1 |
//! | 4 | u32 kind: 0 isotropic (theta_i, theta_o, phi_d), 1 anisotropic (theta_i, theta_o, phi_i, phi_o) |
//! | 20 per dimension | u32 bin count, f64 lower and upper bound in degrees (3 or 4 dimensions) |
//! | 8 | u64 number of non-empty bins |
//! | ceil(bins / 8) | mask: bit k (LSB first) set when bin k holds a value; the last dimension varies fastest |
//! | 12 per non-empty bin | RGB f32 values (1/sr) of the non-empty bins, in index order |
//!
//! phi_d = |phi_o - phi_i| folded into [0, 180] degrees (isotropy and reciprocity).
//!
//! Lookups: [`Binned::bin_of`] finds a bin from f64 angles (fitting, tabulation);
//! rendering uses [`Binned::bin_value`] (written once, for one query or `LANES` in
//! SIMD lanes) with f32 angles from [`crate::fastmath`] (the same bin except within about
//! 1e-4 degrees of a bin edge).

use crate::Rgb;
use crate::error::FileError;
use crate::math::{Num, V3, acos, atan2, gt, lt, maximum, minimum, select};
use glam::Vec3;
use std::path::Path;

pub const MAGIC: &[u8; 8] = b"LOBEBIN1";

/// Degrees per radian, in f32.
const DEGREES: f32 = 180.0 / std::f32::consts::PI;

/// One binned dimension: `count` bins uniform over [min, max) degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    pub count: usize,
    pub min: f64,
    pub max: f64,
}

impl Axis {
    pub const fn new(count: usize, min: f64, max: f64) -> Self {
        Self { count, min, max }
    }
    /// Bin of a value in degrees, clamped.
    #[inline]
    pub fn bin(&self, deg: f64) -> usize {
        let t = (deg - self.min) / (self.max - self.min) * self.count as f64;
        (t.max(0.0) as usize).min(self.count - 1)
    }
    /// [`Axis::bin`] in f32, one value or lanes ([`Binned::bin_value`]).
    #[inline(always)]
    fn bin_index<T: Num>(&self, deg: T) -> T::Int {
        let t = (deg - T::of(self.min)) / T::of(self.max - self.min) * T::of(self.count as f64);
        minimum(maximum(t, T::of(0.0)), T::of((self.count - 1) as f64)).trunc_int()
    }
    /// Centre of bin k in degrees.
    pub fn centre(&self, k: usize) -> f64 {
        self.min + (k as f64 + 0.5) / self.count as f64 * (self.max - self.min)
    }
    pub fn width(&self) -> f64 {
        (self.max - self.min) / self.count as f64
    }
}

/// A binned BRDF.
#[derive(Clone, Debug)]
pub struct Binned {
    pub anisotropic: bool,
    pub axes: Vec<Axis>,
    /// Per bin: the value, or None when empty.
    pub values: Vec<Option<[f32; 3]>>,
}

impl Binned {
    /// The study's isotropic layout: 1-degree bins of theta_i, theta_o in [0, 90) and phi_d in [0, 180].
    pub fn isotropic_layout() -> Vec<Axis> {
        vec![
            Axis::new(90, 0.0, 90.0),
            Axis::new(90, 0.0, 90.0),
            Axis::new(180, 0.0, 180.0),
        ]
    }
    /// The study's anisotropic layout: 2-degree bins of theta_i, theta_o in [0, 90) and phi_i, phi_o in [0, 360).
    pub fn anisotropic_layout() -> Vec<Axis> {
        vec![
            Axis::new(45, 0.0, 90.0),
            Axis::new(45, 0.0, 90.0),
            Axis::new(180, 0.0, 360.0),
            Axis::new(180, 0.0, 360.0),
        ]
    }

    pub fn empty(anisotropic: bool, axes: Vec<Axis>) -> Self {
        let n = axes.iter().map(|a| a.count).product();
        Self {
            anisotropic,
            axes,
            values: vec![None; n],
        }
    }

    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    pub fn filled(&self) -> usize {
        self.values.iter().filter(|v| v.is_some()).count()
    }

    /// Flat index of per-axis bins.
    pub fn index(&self, bins: &[usize]) -> usize {
        bins.iter()
            .zip(&self.axes)
            .fold(0, |acc, (&b, a)| acc * a.count + b)
    }

    /// Per-axis bins of a flat index.
    pub fn unindex(&self, mut k: usize) -> Vec<usize> {
        let mut out = vec![0; self.axes.len()];
        for (d, a) in self.axes.iter().enumerate().rev() {
            out[d] = k % a.count;
            k /= a.count;
        }
        out
    }

    /// Angles (degrees) of a direction pair: (theta_i, theta_o, phi_d) or (theta_i, theta_o,
    /// phi_i, phi_o), and how many of them there are (3 for isotropic tables, 4 for
    /// anisotropic ones); a fixed array, since every lookup needs them.
    pub fn angles(&self, wi: Vec3, wo: Vec3) -> ([f64; 4], usize) {
        let sph = |w: Vec3| {
            let t = (w.z as f64).clamp(-1.0, 1.0).acos().to_degrees();
            let p = (w.y as f64)
                .atan2(w.x as f64)
                .to_degrees()
                .rem_euclid(360.0);
            (t, p)
        };
        let (ti, pi) = sph(wi);
        let (to, po) = sph(wo);
        if self.anisotropic {
            ([ti, to, pi, po], 4)
        } else {
            let mut d = (po - pi).rem_euclid(360.0);
            if d > 180.0 {
                d = 360.0 - d;
            }
            ([ti, to, d, 0.0], 3)
        }
    }

    /// Flat index of the bin of a direction pair (called per lookup: allocates nothing).
    pub fn bin_of(&self, wi: Vec3, wo: Vec3) -> usize {
        let (a, n) = self.angles(wi, wo);
        a[..n]
            .iter()
            .zip(&self.axes)
            .fold(0, |acc, (&x, ax)| acc * ax.count + ax.bin(x))
    }

    /// Direction pair at the centre of bin k (wi, wo).
    pub fn directions(&self, k: usize) -> (Vec3, Vec3) {
        let b = self.unindex(k);
        let c: Vec<f64> = b
            .iter()
            .zip(&self.axes)
            .map(|(&i, a)| a.centre(i))
            .collect();
        self.directions_at(&c)
    }

    /// Direction pair (wi, wo) of angles in degrees, in this table's layout.
    pub fn directions_at(&self, c: &[f64]) -> (Vec3, Vec3) {
        let d = |t: f64, p: f64| {
            let (t, p) = (t.to_radians(), p.to_radians());
            Vec3::new(
                (t.sin() * p.cos()) as f32,
                (t.sin() * p.sin()) as f32,
                t.cos() as f32,
            )
        };
        if self.anisotropic {
            (d(c[0], c[2]), d(c[1], c[3]))
        } else {
            (d(c[0], 0.0), d(c[1], c[2]))
        }
    }

    /// A value-less copy of the layout (for index arithmetic on other threads).
    pub fn clone_shape(&self) -> Self {
        Self {
            anisotropic: self.anisotropic,
            axes: self.axes.clone(),
            values: Vec::new(),
        }
    }

    /// Nearest-bin value (zero for an empty bin or below the surface).
    pub fn lookup(&self, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.values[self.bin_of(wi, wo)].map_or(Rgb::ZERO, Rgb::from)
    }

    /// [`Binned::lookup`] in f32 (rendering), written once over [`Num`] (one pair, or lanes
    /// of pairs): the bin of the pair's angles in f32, zero for an empty bin and below the
    /// surface.
    #[inline]
    pub fn bin_value<T: Num>(&self, wi: V3<T>, wo: V3<T>) -> [T; 3] {
        let s = T::of;
        let sph = |w: V3<T>| {
            let t = acos(minimum(maximum(w.z, s(-1.0)), s(1.0))) * s(DEGREES as f64);
            let p = atan2(w.y, w.x) * s(DEGREES as f64);
            (t, select(lt(p, s(0.0)), p + s(360.0), p))
        };
        let ((ti, pi), (to, po)) = (sph(wi), sph(wo));
        let a = &self.axes;
        let count = |d: usize| T::int(a[d].count as i32);
        let k = if self.anisotropic {
            ((a[0].bin_index(ti) * count(1) + a[1].bin_index(to)) * count(2) + a[2].bin_index(pi))
                * count(3)
                + a[3].bin_index(po)
        } else {
            let d = po - pi;
            let d = select(lt(d, s(0.0)), d + s(360.0), d);
            let d = select(gt(d, s(180.0)), s(360.0) - d, d);
            (a[0].bin_index(ti) * count(1) + a[1].bin_index(to)) * count(2) + a[2].bin_index(d)
        };
        let above = gt(wi.z, s(0.0)) & gt(wo.z, s(0.0));
        let v = T::gather_by(k, |k| self.values[k].unwrap_or([0.0; 3]));
        v.map(|x| select(above, x, s(0.0)))
    }

    /// Fills empty bins by repeatedly averaging their non-empty neighbours (along every
    /// axis, periodic in the azimuths), for rendering a table with holes.
    pub fn filled_copy(&self) -> Self {
        let mut out = self.clone();
        if out.filled() == 0 {
            return out;
        }
        let periodic: Vec<bool> = self
            .axes
            .iter()
            .enumerate()
            .map(|(d, a)| d >= 2 && (a.max - a.min) >= 360.0)
            .collect();
        loop {
            let empty: Vec<usize> = (0..out.len())
                .filter(|&k| out.values[k].is_none())
                .collect();
            if empty.is_empty() {
                break;
            }
            let mut updates = Vec::new();
            for &k in &empty {
                let b = out.unindex(k);
                let mut acc = [0.0f64; 3];
                let mut n = 0;
                for d in 0..b.len() {
                    for step in [-1i64, 1] {
                        let mut nb = b.clone();
                        let v = b[d] as i64 + step;
                        let c = out.axes[d].count as i64;
                        nb[d] = if periodic[d] {
                            v.rem_euclid(c) as usize
                        } else if v < 0 || v >= c {
                            continue;
                        } else {
                            v as usize
                        };
                        if let Some(x) = out.values[out.index(&nb)] {
                            for k in 0..3 {
                                acc[k] += x[k] as f64;
                            }
                            n += 1;
                        }
                    }
                }
                if n > 0 {
                    updates.push((
                        k,
                        [
                            (acc[0] / n as f64) as f32,
                            (acc[1] / n as f64) as f32,
                            (acc[2] / n as f64) as f32,
                        ],
                    ));
                }
            }
            if updates.is_empty() {
                break;
            }
            for (k, v) in updates {
                out.values[k] = Some(v);
            }
        }
        out
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&1u32.to_le_bytes());
        out.extend_from_slice(&(self.anisotropic as u32).to_le_bytes());
        out.extend_from_slice(&(self.axes.len() as u32).to_le_bytes());
        for a in &self.axes {
            out.extend_from_slice(&(a.count as u32).to_le_bytes());
            out.extend_from_slice(&a.min.to_le_bytes());
            out.extend_from_slice(&a.max.to_le_bytes());
        }
        out.extend_from_slice(&(self.filled() as u64).to_le_bytes());
        let mut mask = vec![0u8; self.len().div_ceil(8)];
        for (k, v) in self.values.iter().enumerate() {
            if v.is_some() {
                mask[k / 8] |= 1 << (k % 8);
            }
        }
        out.extend_from_slice(&mask);
        for v in self.values.iter().flatten() {
            for x in v {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out
    }

    pub fn write(&self, path: &Path) -> Result<(), FileError> {
        let bytes = self.to_bytes();
        crate::io::atomic_write(path, |w| std::io::Write::write_all(w, &bytes))
    }

    pub fn read(path: &Path) -> Result<Self, FileError> {
        let shown = path.display().to_string();
        let bytes = crate::io::read_regular(path, crate::io::MAX_DATA_BYTES, "a binned BRDF file")?;
        Self::from_bytes(&bytes, &shown)
    }

    pub fn from_bytes(b: &[u8], name: &str) -> Result<Self, FileError> {
        let b_unindex = |axes: &[Axis], k: usize| {
            Self {
                anisotropic: false,
                axes: axes.to_vec(),
                values: Vec::new(),
            }
            .unindex(k)
        };
        let err = |m: String| FileError::new(name, m);
        let mut pos = 0usize;
        let mut take = |n: usize, what: &str| -> Result<&[u8], FileError> {
            if pos + n > b.len() {
                return Err(FileError::new(
                    name,
                    format!(
                        "truncated in the {what}: {} bytes, expected at least {}",
                        b.len(),
                        pos + n
                    ),
                ));
            }
            let s = &b[pos..pos + n];
            pos += n;
            Ok(s)
        };
        if take(8, "magic")? != MAGIC {
            return Err(err(
                "does not start with LOBEBIN1; expected a lobe binned BRDF file".into(),
            ));
        }
        let u32_at = |s: &[u8]| u32::from_le_bytes(s.try_into().expect("4 bytes"));
        let version = u32_at(take(4, "header")?);
        if version != 1 {
            return Err(err(format!("version {version}; expected 1")));
        }
        let kind = u32_at(take(4, "header")?);
        let ndim = u32_at(take(4, "header")?) as usize;
        let expected_dims = match kind {
            0 => 3,
            1 => 4,
            k => {
                return Err(err(format!(
                    "kind {k}; expected 0 (isotropic) or 1 (anisotropic)"
                )));
            }
        };
        if ndim != expected_dims {
            return Err(err(format!(
                "{ndim} dimensions; expected {expected_dims} for kind {kind}"
            )));
        }
        let mut axes = Vec::new();
        for d in 0..ndim {
            let count = u32_at(take(4, "axes")?) as usize;
            let min = f64::from_le_bytes(take(8, "axes")?.try_into().expect("8"));
            let max = f64::from_le_bytes(take(8, "axes")?.try_into().expect("8"));
            if count == 0 || count > 100_000 || !(max > min) || !min.is_finite() || !max.is_finite()
            {
                return Err(err(format!(
                    "axis {d}: {count} bins over [{min}, {max}); expected a positive count and an increasing finite range"
                )));
            }
            axes.push(Axis::new(count, min, max));
        }
        let total: usize = axes
            .iter()
            .try_fold(1usize, |a, x| a.checked_mul(x.count))
            .filter(|&t| t <= 1usize << 34)
            .ok_or_else(|| err("too many bins".into()))?;
        let filled = u64::from_le_bytes(take(8, "header")?.try_into().expect("8")) as usize;
        let mask = take(total.div_ceil(8), "mask")?.to_vec();
        let set = (0..total)
            .filter(|&k| mask[k / 8] & (1 << (k % 8)) != 0)
            .count();
        if set != filled {
            return Err(err(format!(
                "the mask marks {set} bins, the header says {filled}"
            )));
        }
        let expected_len = pos + 12 * filled;
        if b.len() != expected_len {
            return Err(err(format!(
                "{} bytes; expected {expected_len} for {filled} non-empty bins: the file is {}",
                b.len(),
                if b.len() < expected_len {
                    "truncated"
                } else {
                    "too long"
                }
            )));
        }
        let mut values = vec![None; total];
        let mut p = pos;
        for (k, v) in values.iter_mut().enumerate() {
            if mask[k / 8] & (1 << (k % 8)) != 0 {
                let f = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().expect("4"));
                let x = [f(p), f(p + 4), f(p + 8)];
                if !x.iter().all(|c| c.abs() as f64 <= super::MAX_VALUE) {
                    let at: Vec<String> = b_unindex(&axes, k)
                        .iter()
                        .zip(&axes)
                        .map(|(&i, a)| format!("{}", a.centre(i)))
                        .collect();
                    return Err(err(format!(
                        "bin {k} (centre at [{}] degrees) holds {x:?}; expected finite values of magnitude up to {:e} 1/sr",
                        at.join(", "),
                        super::MAX_VALUE
                    )));
                }
                *v = Some(x);
                p += 12;
            }
        }
        Ok(Self {
            anisotropic: kind == 1,
            axes,
            values,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::{self, LANES, RgbxN, Vec3xN};

    /// The f32 lookups of rendering find the bin the f64 angles find, except within
    /// 1e-3 degrees of a bin edge, and the lane form equals the single one bit for
    /// bit; empty bins and pairs below the surface give zero.
    #[test]
    fn f32_lookups_find_the_f64_bin() {
        for anisotropic in [false, true] {
            // Anisotropic: the study's theta bins, 10-degree azimuths (a smaller table).
            let axes = if anisotropic {
                let mut a = Binned::anisotropic_layout();
                a[2] = Axis::new(36, 0.0, 360.0);
                a[3] = Axis::new(36, 0.0, 360.0);
                a
            } else {
                Binned::isotropic_layout()
            };
            let mut t = Binned::empty(anisotropic, axes);
            for (k, v) in t.values.iter_mut().enumerate() {
                // Bin k holds k (exact in f32 below 2^24), every eleventh bin is empty.
                *v = (k % 11 != 5).then_some([k as f32, 1.0, 2.0]);
            }
            let dir = |k: usize, a: f32, b: f32| {
                let z = ((k as f32 * a + 0.05).fract()) * 1.2 - 0.2;
                let phi = std::f32::consts::TAU * (k as f32 * b + 0.3).fract();
                let s = (1.0 - z * z).max(0.0).sqrt();
                Vec3::new(s * phi.cos(), s * phi.sin(), z)
            };
            let (mut same, mut edge) = (0, 0);
            for chunk in 0..16_000 / LANES {
                let wi: [Vec3; LANES] =
                    simd::lanes(|i| dir(LANES * chunk + i, 0.618_034, 0.414_214));
                let wo: [Vec3; LANES] =
                    simd::lanes(|i| dir(LANES * chunk + i + 5, 0.754_878, 0.569_840));
                let [r, g, b] = t.bin_value(Vec3xN::from_array(&wi), Vec3xN::from_array(&wo));
                let lanes = RgbxN::new(r, g, b);
                for i in 0..LANES {
                    let one = Rgb::from(t.bin_value::<f32>(wi[i].into(), wo[i].into()));
                    let lane = lanes.lane(i);
                    assert_eq!(
                        [one.r, one.g, one.b].map(f32::to_bits),
                        [lane.r, lane.g, lane.b].map(f32::to_bits)
                    );
                    if wi[i].z <= 0.0 || wo[i].z <= 0.0 {
                        assert_eq!(one, Rgb::ZERO);
                        continue;
                    }
                    let (a, n) = t.angles(wi[i], wo[i]);
                    let near_edge = a[..n].iter().zip(&t.axes).any(|(&x, ax)| {
                        // Edges between bins (the clamped ends are no edge).
                        let f = (x - ax.min) / ax.width();
                        let interior = f.round() >= 1.0 && f.round() < ax.count as f64;
                        interior && (f - f.round()).abs() * ax.width() < 1e-3
                    });
                    if near_edge {
                        edge += 1;
                    } else {
                        assert_eq!(
                            one,
                            t.lookup(wi[i], wo[i]),
                            "wi {:?}, wo {:?}",
                            wi[i],
                            wo[i]
                        );
                        same += 1;
                    }
                }
            }
            assert!(
                same > 10_000 && edge < 100,
                "{same} compared, {edge} at an edge"
            );
        }
    }
}
