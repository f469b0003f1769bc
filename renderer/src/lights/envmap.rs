//! Lat-long HDR environment maps with Mitsuba 3's `envmap` conventions, importance
//! sampled by luminance x sin(theta).
//!
//! Direction convention (docs/scene-format.md, "Environment maps"): in the emitter's local
//! frame, +y is up; a direction d = (x, y, z) maps to texture coordinates
//! u = atan2(x, -z) / (2 pi) (wrapped to [0, 1)) and v = acos(y) / pi, with v = 0 the top
//! row of the image. The radiance is the bilinear interpolation of the pixels, with row
//! j at v = j / (H - 1) and column i at u = (i + 1/2) / W, wrapping around in u: exactly the
//! lookup of Mitsuba 3's `envmap` plugin, so one file lights a scene the same way in both
//! renderers. `to_world` (a rotation) maps local directions to world ones, and `scale`
//! multiplies the radiance.
//!
//! Sampling: the density over the (u, v) square is the bilinear interpolation of corner
//! weights luminance x sin(theta) of each pixel (as Mitsuba 3's bilinear `Hierarchical2D`
//! warp of its envmap): a cell of the W x (H - 1) grid is drawn with probability the mean
//! of its corner weights (the integral of its bilinear patch) by hierarchical sample
//! warping ([`Hierarchy2D`]: Clarberg et al. 2005, as Mitsuba), then a point within it
//! with pbrt-v4's `SampleBilinear`. The ratio radiance / pdf is then smooth across cells
//! (no step per cell), and nearby samples land nearby at every scale, so low-discrepancy
//! samples stay stratified (light samples alone on sphere-envmap at 64 spp: 1.9x lower
//! variance than the rows-then-columns CDF inversion used before). The density is
//! positive wherever the radiance is (away from the poles, which have no solid angle), so
//! the estimator stays unbiased. With MIS compensation (Karlik et al. 2019, optional) the
//! weights are max(luminance - mean, 0) x sin(theta): zero where the map is darker than
//! its mean, which BSDF sampling must then cover (the scene loader checks that it does).

use crate::Rgb;
use crate::error::{Error, Result};
use crate::image_io::{RgbImage, read_rgb_image_windows};
use glam::{Mat3, Vec2, Vec3};
use lobe_materials::columns::{Vec2Cols, Vec3Cols, Vec3ColsMut};
use lobe_materials::math::{
    Num, V3, acos, atan2, clamp, floor, gt, le, lt, maximum, minimum, select, sin_cos, sqrt,
};
use lobe_materials::sampling::hierarchy::Hierarchy2D;
use lobe_materials::sampling::warp::bilinear;
use lobe_materials::simd;
use lobe_materials::simd::{LANES, RgbxN, Vec3xN, f32xn, i32xn, u32xn};
use std::f32::consts::{PI, TAU};
use std::path::Path;

#[derive(Clone, Debug)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// H rows of W + 1 pixels, three floats (r, g, b) each: the last column repeats the
    /// first (periodic boundary). Flat, so that the SIMD lookups load a pixel pair of
    /// `LANES` cells as 16-byte rows and transpose them ([`simd::transpose4xn`]).
    data: Vec<f32>,
    scale: f32,
    to_world: Mat3,
    to_local: Mat3,
    /// Cell sampler; a cell's density is recomputed from the same four corners the
    /// radiance lookup reads, so sampling and evaluation touch the same cache lines.
    cells: Hierarchy2D,
    /// sin(theta) of each row of pixels (theta = pi j / (H - 1)).
    sin_row: Vec<f32>,
    /// 1 / mean cell weight (0 when the map is black: uniform sampling).
    inv_mean: f32,
    /// Luminance subtracted from every pixel's sampling weight (MIS compensation; 0 when
    /// off).
    offset: f32,
}

/// Environment-map sampling distributions built since the process started: lets tests show
/// that a scene without an environment map builds none.
pub static DISTRIBUTIONS_BUILT: std::sync::atomic::AtomicUsize =
    std::sync::atomic::AtomicUsize::new(0);

impl EnvMap {
    /// From linear RGB pixels (negative and non-finite components read as zero);
    /// `to_world` must be a rotation (an orthonormal matrix).
    pub fn new(img: &RgbImage, scale: f32, to_world: Mat3) -> Self {
        Self::with_mis_compensation(img, scale, to_world, false)
    }

    /// [`EnvMap::new`], optionally with MIS compensation (Karlik et al., "MIS
    /// Compensation: Optimizing Sampling Techniques in Multiple Importance Sampling",
    /// SIGGRAPH Asia 2019; Mitsuba 3's `mis_compensation`): the sampling weights are
    /// max(luminance - mean luminance, 0) x sin(theta), so light samples go only where the
    /// map is brighter than average and BSDF samples, combined by MIS, cover the rest.
    /// Unbiased only when every path vertex also samples its BSDF (the scene loader
    /// checks it). Left off for nearly constant maps (mean - minimum <= 1 % of the mean),
    /// as Mitsuba does.
    pub fn with_mis_compensation(
        img: &RgbImage,
        scale: f32,
        to_world: Mat3,
        compensate: bool,
    ) -> Self {
        DISTRIBUTIONS_BUILT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let (w, h) = (img.width, img.height);
        assert!(w >= 2 && h >= 3 && img.pixels.len() == w * h);
        let mut data = Vec::with_capacity((w + 1) * h * 3);
        // Negative and non-finite components are zero (as `load_rgb_image` makes them), so
        // luminance is non-negative and linear over the bilinear lookup, which the density
        // relies on.
        let clean = |c: &Rgb| c.map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 });
        for row in img.pixels.chunks(w) {
            for c in row.iter().chain(&row[..1]).map(clean) {
                data.extend([c.r, c.g, c.b]);
            }
        }
        let sin_row: Vec<f32> = (0..h)
            .map(|j| (j as f32 / (h - 1) as f32 * PI).sin().max(0.0))
            .collect();
        let offset = if compensate {
            let (mut sum, mut min) = (0.0f64, f32::INFINITY);
            for p in &img.pixels {
                let l = clean(p).luminance().max(0.0);
                sum += l as f64;
                min = min.min(l);
            }
            let mean = (sum / img.pixels.len() as f64) as f32;
            if mean - min <= 0.01 * mean { 0.0 } else { mean }
        } else {
            0.0
        };
        let mut cells = vec![0.0f32; w * (h - 1)];
        for j in 0..h - 1 {
            for i in 0..w {
                // The integral of the bilinear patch: the mean of its corner weights.
                let (t, s_top, s_bottom) =
                    cell_corners::<f32>(&data, &sin_row, w, i as i32, j as i32);
                let c = corner_weights(&t, s_top, s_bottom, offset);
                cells[j * w + i] = 0.25 * (c[0] + c[1] + c[2] + c[3]);
            }
        }
        let black = !cells.iter().any(|&c| c > 0.0);
        let (table, mean) = Hierarchy2D::new(&cells, w, h - 1);
        Self {
            width: w,
            height: h,
            data,
            scale,
            to_world,
            to_local: to_world.transpose(),
            cells: table,
            sin_row,
            inv_mean: if black { 0.0 } else { (1.0 / mean) as f32 },
            offset,
        }
    }

    pub fn resolution(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The bilinear cell of texture coordinates (u, v): its column and row and the
    /// fractional position within it.
    #[inline(always)]
    fn texel_cell<T: Num>(&self, u: T, v: T) -> (T::Int, T::Int, T, T) {
        let (w, h) = (self.width, self.height);
        let x = u - T::of((0.5 / w as f32) as f64);
        let x = (x - floor(x)) * T::of(w as f64);
        let y = (v - floor(v)) * T::of((h - 1) as f64);
        let ix = T::int_min(T::int_max(x.trunc_int(), T::int(0)), T::int(w as i32 - 1));
        let iy = T::int_min(T::int_max(y.trunc_int(), T::int(0)), T::int(h as i32 - 2));
        (ix, iy, x - T::of_int(ix), y - T::of_int(iy))
    }

    /// Radiance (without `scale`) and the density of [`EnvMap::sample`] over the unit
    /// square of (u, v) at (`fx`, `fy`) in a cell with corner texels `t`, whose pixel rows
    /// have sin(theta) `s_top` and `s_bottom`: both interpolate the same four texels. The
    /// density is the bilinear interpolation of the corner weights (luminance x sin(theta)
    /// of the row) over their mean: the cell's probability times the bilinear density
    /// within it.
    #[inline(always)]
    fn blend<T: Num>(&self, t: &[[T; 3]; 4], s_top: T, s_bottom: T, fx: T, fy: T) -> ([T; 3], T) {
        let one = T::of(1.0);
        let mix = |a: [T; 3], b: [T; 3], f: T| std::array::from_fn(|c| a[c] * (one - f) + b[c] * f);
        let top = mix(t[0], t[1], fx);
        let bottom = mix(t[2], t[3], fx);
        let texel = mix(top, bottom, fy);
        let inv_mean = T::of(self.inv_mean as f64);
        let density = if self.inv_mean == 0.0 {
            one
        } else if self.offset > 0.0 {
            // With MIS compensation the weights are clamped per pixel, so they are
            // interpolated one by one.
            let c = corner_weights(t, s_top, s_bottom, self.offset);
            ((one - fy) * (c[0] * (one - fx) + c[1] * fx) + fy * (c[2] * (one - fx) + c[3] * fx))
                * inv_mean
        } else {
            // Luminance is linear: that of the interpolated rows is the interpolated one.
            let zero = T::of(0.0);
            ((one - fy) * maximum(luminance(top), zero) * s_top
                + fy * maximum(luminance(bottom), zero) * s_bottom)
                * inv_mean
        };
        (texel, density)
    }

    /// Radiance arriving from world direction `d` (unit; pointing away from the scene).
    #[inline]
    pub fn eval(&self, d: Vec3) -> Rgb {
        self.eval_pdf(d).0
    }

    /// Radiance from world direction `d` and the solid-angle density with which
    /// [`EnvMap::sample`] picks it, sharing the coordinate computation.
    #[inline]
    pub fn eval_pdf(&self, d: Vec3) -> (Rgb, f32) {
        let (radiance, pdf) = self.radiance_pdf::<f32>(d.into());
        (Rgb::from(radiance), pdf)
    }

    /// [`EnvMap::eval_pdf`] written once over [`Num`] (one direction, or lanes of them):
    /// the texture coordinates, the cell, the blend of its texels and of their weights.
    #[inline(always)]
    fn radiance_pdf<T: Num>(&self, d: V3<T>) -> ([T; 3], T) {
        let w = self.width;
        let zero = T::of(0.0);
        let l = mat3_mul(&self.to_local, d);
        // Texture coordinates: u = atan2(x, -z) / (2 pi) wrapped to [0, 1), v = acos(y) / pi.
        let u = atan2(l.x, -l.z) * T::of((1.0 / TAU) as f64);
        let u = select(lt(u, zero), u + T::of(1.0), u);
        let v = acos(clamp(l.y, T::of(-1.0), T::of(1.0))) * T::of((1.0 / PI) as f64);
        let (ix, iy, fx, fy) = self.texel_cell(u, v);
        let (t, s_top, s_bottom) = cell_corners(&self.data, &self.sin_row, w, ix, iy);
        let (texel, density) = self.blend(&t, s_top, s_bottom, fx, fy);
        let radiance = texel.map(|c| c * T::of(self.scale as f64));
        let st = sqrt(l.x * l.x + l.z * l.z);
        let pdf = density / (T::of((2.0 * PI * PI) as f64) * st);
        (radiance, select(le(st, T::of(1e-7)), zero, pdf))
    }

    /// [`EnvMap::eval_pdf`] of many directions, `out[i]` for `dirs[i]`, bit for bit the
    /// same: a lane vector at a time, so that the independent texel reads of `LANES`
    /// lookups overlap and the arithmetic runs once per `LANES` directions.
    pub fn eval_pdf_many(&self, dirs: Vec3Cols, out: &mut [(Rgb, f32)]) {
        assert_eq!(dirs.len(), out.len());
        for (c, oc) in out.chunks_mut(LANES).enumerate() {
            let ([r, g, b], pdf) = self.radiance_pdf(dirs.load(LANES * c));
            let radiance = RgbxN::new(r, g, b);
            let pdf = pdf.to_array();
            for (i, o) in oc.iter_mut().enumerate() {
                *o = (radiance.lane(i), pdf[i]);
            }
        }
    }

    /// [`EnvMap::sample`] of many points, bit for bit the same, a lane vector at a time in SIMD
    /// lanes as [`EnvMap::eval_pdf_many`]: for `us[i]`, the direction `wi[i]`, radiance
    /// `li[i]` and pdf `pdf[i]`, or a pdf of 0 (and zero direction and radiance) where
    /// `sample` gives None.
    pub fn sample_many(&self, us: Vec2Cols, mut wi: Vec3ColsMut, li: &mut [Rgb], pdf: &mut [f32]) {
        assert!(us.len() == wi.len() && us.len() == li.len() && us.len() == pdf.len());
        let zero = f32xn::splat(0.0);
        // Two lane vectors of points at a time: two groups descend the hierarchy side by side
        // (two independent dependency chains the core overlaps; three or four groups
        // measured no faster), then each goes on alone.
        const GROUPS: usize = 2;
        let n = us.len();
        for (c2, first) in (0..n).step_by(LANES * GROUPS).enumerate() {
            let [x0, y0] = us.load(first);
            let cells = match first + LANES < n {
                true => {
                    let [x1, y1] = us.load(first + LANES);
                    self.cells.sample_groups([x0, x1], [y0, y1])
                }
                // A lone group descends alone.
                false => {
                    let [c] = self.cells.sample_groups([x0], [y0]);
                    [c, c]
                }
            };
            let end = (first + LANES * GROUPS).min(n);
            for (g, start) in (first..end).step_by(LANES).enumerate() {
                let len = (end - start).min(LANES);
                let (cx, cy, rx, ry) = cells[g];
                let as_int = |c: u32xn| i32xn::new(c.to_array().map(|v| v as i32));
                let (d, radiance, p, valid) = self.sample_in_cell(as_int(cx), as_int(cy), rx, ry);
                // Invalid lanes get a zero direction, radiance and pdf.
                let keep = |v: f32xn| simd::sel(valid, v, zero);
                let [r, gr, b] = simd::arrays3(radiance.map(keep));
                let p = keep(p).to_array();
                let base = LANES * (GROUPS * c2 + g);
                wi.store(base, Vec3xN::new(keep(d.x), keep(d.y), keep(d.z)));
                for i in 0..len {
                    let o = base + i;
                    li[o] = Rgb::new(r[i], gr[i], b[i]);
                    pdf[o] = p[i];
                }
            }
        }
    }

    /// Solid-angle density of [`EnvMap::sample`] for world direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.eval_pdf(d).1
    }

    /// Samples a world direction: (direction, radiance, solid-angle pdf).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        let (ix, iy, r) = self.cells.sample(u);
        let (d, radiance, pdf, valid) = self.sample_in_cell::<f32>(ix as i32, iy as i32, r.x, r.y);
        valid.then(|| (d.into(), Rgb::from(radiance), pdf))
    }

    /// The direction, radiance and solid-angle density of the point (`rx`, `ry`) of the
    /// unit square mapped into cell (`ix`, `iy`) (drawn by the hierarchy), and where it is
    /// a sample (off the poles, of positive density); one point or lanes of points.
    /// Within the cell the point follows the bilinear density of the corner weights
    /// (uniform for a black map), so the radiance over the density is smooth, not stepped
    /// per cell; the radiance and density are the lookup [`EnvMap::eval_pdf`] makes at the
    /// sampled direction, without finding the cell again.
    #[inline(always)]
    fn sample_in_cell<T: Num>(
        &self,
        ix: T::Int,
        iy: T::Int,
        rx: T,
        ry: T,
    ) -> (V3<T>, [T; 3], T, T::Mask) {
        let (w, h) = (self.width, self.height);
        let (zero, one) = (T::of(0.0), T::of(1.0));
        let (t, s_top, s_bottom) = cell_corners(&self.data, &self.sin_row, w, ix, iy);
        let (fx, fy) = if self.inv_mean == 0.0 {
            (rx, ry)
        } else {
            bilinear(rx, ry, corner_weights(&t, s_top, s_bottom, self.offset))
        };
        let below_one = T::of((1.0 - f32::EPSILON / 2.0) as f64);
        let ax = minimum((T::of_int(ix) + fx) / T::of(w as f64), below_one);
        let vv = minimum((T::of_int(iy) + fy) / T::of((h - 1) as f64), below_one);
        let x = ax + T::of((0.5 / w as f32) as f64);
        let uu = select(le(one, x), x - one, x);
        let (st, ct) = sin_cos(vv * T::of(PI as f64));
        let (sp, cp) = sin_cos(uu * T::of(TAU as f64));
        let (texel, pdf_ab) = self.blend(&t, s_top, s_bottom, fx, fy);
        let valid = gt(st, T::of(1e-7)) & gt(pdf_ab, zero);
        let d = mat3_mul(&self.to_world, V3::new(st * sp, ct, -(st * cp)));
        let radiance = texel.map(|c| c * T::of(self.scale as f64));
        let pdf = pdf_ab / (T::of((2.0 * PI * PI) as f64) * st);
        (d, radiance, pdf, valid)
    }
}

/// The corner texels of cell (`ix`, `iy`) of flat r, g, b `data` with rows of `w + 1`
/// texels ([top-left, top-right, bottom-left, bottom-right]), and the sines of its top and
/// bottom pixel rows. A texel pair is six floats, r0 g0 b0 r1 g1 b1, read as two
/// overlapping 4-float loads ([`Num::gather4`]: in lanes, transposed).
#[inline(always)]
fn cell_corners<T: Num>(
    data: &[f32],
    sin_row: &[f32],
    w: usize,
    ix: T::Int,
    iy: T::Int,
) -> ([[T; 3]; 4], T, T) {
    let k = (iy * T::int(w as i32 + 1) + ix) * T::int(3);
    let (tl, tr) = texel_pair(data, k);
    let (bl, br) = texel_pair(data, k + T::int(3 * (w as i32 + 1)));
    let s = |j: i32| T::gather(sin_row, iy + T::int(j));
    ([tl, tr, bl, br], s(0), s(1))
}

/// The texels whose r, g, b start at float `at` and `at + 3` of `data`: two overlapping
/// 4-float loads.
#[inline(always)]
fn texel_pair<T: Num>(data: &[f32], at: T::Int) -> ([T; 3], [T; 3]) {
    let a = T::gather4(data, at);
    let b = T::gather4(data, at + T::int(2));
    ([a[0], a[1], a[2]], [a[3], b[2], b[3]])
}

/// Sampling weights of the four corners `t` of a cell whose pixel rows have sin(theta)
/// `s_top` and `s_bottom`: (luminance - `offset`, at least 0) x sin(theta) of each
/// corner's row.
#[inline(always)]
fn corner_weights<T: Num>(t: &[[T; 3]; 4], s_top: T, s_bottom: T, offset: f32) -> [T; 4] {
    let w = |c: [T; 3], s: T| maximum(luminance(c) - T::of(offset as f64), T::of(0.0)) * s;
    [
        w(t[0], s_top),
        w(t[1], s_top),
        w(t[2], s_bottom),
        w(t[3], s_bottom),
    ]
}

/// [`Rgb::luminance`] over [`Num`].
#[inline(always)]
fn luminance<T: Num>(c: [T; 3]) -> T {
    let k = |x: f32| T::of(x as f64);
    k(0.212671) * c[0] + k(0.715160) * c[1] + k(0.072169) * c[2]
}

/// `m * v` with glam's `Mat3 * Vec3` operations.
#[inline(always)]
fn mat3_mul<T: Num>(m: &Mat3, v: V3<T>) -> V3<T> {
    let k = |x: f32| T::of(x as f64);
    let row = |c: usize| k(m.x_axis[c]) * v.x + k(m.y_axis[c]) * v.y + k(m.z_axis[c]) * v.z;
    V3::new(row(0), row(1), row(2))
}

/// Reads an environment map image (see [`crate::image_io::read_rgb_image`]) and checks it:
/// a whole image (its data window is its display window), at least 2x3 pixels, non-finite
/// pixels rejected, negative ones (ringing of lossy sources) clamped to zero.
pub fn load_rgb_image(path: &Path) -> Result<RgbImage> {
    let (img, windows) = read_rgb_image_windows(path)?;
    let name = path.display().to_string();
    windows.require_whole(&name)?;
    validate_image(img, &name)
}

fn validate_image(mut img: RgbImage, name: &str) -> Result<RgbImage> {
    if img.width < 2 || img.height < 3 {
        return Err(Error::file(
            name,
            format!(
                "resolution {}x{}; an environment map needs at least 2x3 pixels",
                img.width, img.height
            ),
        ));
    }
    for (k, p) in img.pixels.iter_mut().enumerate() {
        if !p.is_finite() {
            return Err(Error::file(
                name,
                format!(
                    "pixel ({}, {}) is {:?}; expected finite radiance",
                    k % img.width,
                    k / img.width,
                    p.to_array()
                ),
            ));
        }
        *p = p.map(|c| c.max(0.0));
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_centres_map_to_mitsuba_directions() {
        // One bright pixel at column i, row j: its direction is theta = j pi / (H - 1),
        // phi = (i + 1/2) 2 pi / W, local d = (sin t sin p, cos t, -sin t cos p).
        let (w, h) = (8, 5);
        let mut px = vec![Rgb::ZERO; w * h];
        px[2 * w + 1] = Rgb::ONE;
        let env = EnvMap::new(
            &RgbImage {
                width: w,
                height: h,
                pixels: px,
            },
            1.0,
            Mat3::IDENTITY,
        );
        let theta = 2.0 * PI / 4.0;
        let phi = 1.5 * TAU / 8.0;
        let d = Vec3::new(
            theta.sin() * phi.sin(),
            theta.cos(),
            -theta.sin() * phi.cos(),
        );
        assert!((env.eval(d).r - 1.0).abs() < 1e-4, "{:?}", env.eval(d));
    }
}
