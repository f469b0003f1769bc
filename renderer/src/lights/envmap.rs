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
use lobe_materials::fastmath::{self, xn};
use lobe_materials::sampling::hierarchy::Hierarchy2D;
use lobe_materials::sampling::warp::{bilinear, square_to_bilinear};
use lobe_materials::simd;
use lobe_materials::simd::{LANES, RgbxN, f32xn, i32xn, u32xn};
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
                let c = Self::corner_weights(&data, &sin_row, offset, w, i, j);
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

    /// Sampling weights of the four corners of cell (ix, iy), [top-left, top-right,
    /// bottom-left, bottom-right]: (luminance - `offset`, at least 0) x sin(theta) of each
    /// corner's pixel row.
    #[inline(always)]
    fn corner_weights(
        d: &[f32],
        sin_row: &[f32],
        offset: f32,
        w: usize,
        ix: usize,
        iy: usize,
    ) -> [f32; 4] {
        let k = iy * (w + 1) + ix;
        let (st, sb) = (sin_row[iy], sin_row[iy + 1]);
        let l = |k| (texel(d, k).luminance() - offset).max(0.0);
        [
            l(k) * st,
            l(k + 1) * st,
            l(k + w + 1) * sb,
            l(k + w + 2) * sb,
        ]
    }

    pub fn resolution(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Bilinear lookup at Mitsuba's texture coordinates (u, v).
    #[inline]
    fn lookup(&self, u: f32, v: f32) -> Rgb {
        self.lookup_density(u, v).0 * self.scale
    }

    /// Bilinear lookup (without `scale`) and the density of [`EnvMap::sample`] over the unit
    /// square of (u, v): the bilinear interpolation of the corner weights
    /// (luminance x sin(theta) of the row) over their mean, which is the cell's probability
    /// times the bilinear density within it. Both come from the same four texels.
    #[inline]
    fn lookup_density(&self, u: f32, v: f32) -> (Rgb, f32) {
        self.blend(self.texel_cell(u, v))
    }

    /// The bilinear cell of texture coordinates (u, v): (index of its top-left texel in
    /// `data`, its row, fractional position within it).
    #[inline(always)]
    fn texel_cell(&self, u: f32, v: f32) -> (usize, usize, f32, f32) {
        let (w, h) = (self.width, self.height);
        let mut x = u - 0.5 / w as f32;
        x -= x.floor();
        let mut y = v;
        y -= y.floor();
        let x = x * w as f32;
        let y = y * (h - 1) as f32;
        let ix = (x as usize).min(w - 1);
        let iy = (y as usize).min(h - 2);
        (iy * (w + 1) + ix, iy, x - ix as f32, y - iy as f32)
    }

    /// Radiance (without `scale`) and sampling density at a point of a cell from
    /// [`EnvMap::texel_cell`]: both interpolate the same four texels.
    #[inline(always)]
    fn blend(&self, (k, iy, fx, fy): (usize, usize, f32, f32)) -> (Rgb, f32) {
        let (d, w) = (&self.data, self.width);
        let top = texel(d, k) * (1.0 - fx) + texel(d, k + 1) * fx;
        let bottom = texel(d, k + w + 1) * (1.0 - fx) + texel(d, k + w + 2) * fx;
        let texel = top * (1.0 - fy) + bottom * fy;
        // Luminance is linear: that of the interpolated rows is the interpolated luminance.
        let density = if self.inv_mean == 0.0 {
            1.0
        } else if self.offset > 0.0 {
            // With MIS compensation the weights are clamped per pixel, so they are
            // interpolated one by one.
            let c = Self::corner_weights(d, &self.sin_row, self.offset, w, k % (w + 1), iy);
            ((1.0 - fy) * (c[0] * (1.0 - fx) + c[1] * fx) + fy * (c[2] * (1.0 - fx) + c[3] * fx))
                * self.inv_mean
        } else {
            ((1.0 - fy) * top.luminance().max(0.0) * self.sin_row[iy]
                + fy * bottom.luminance().max(0.0) * self.sin_row[iy + 1])
                * self.inv_mean
        };
        (texel, density)
    }

    /// Local direction -> Mitsuba texture coordinates.
    #[inline]
    fn uv_of(d: Vec3) -> Vec2 {
        let mut u = fastmath::atan2(d.x, -d.z) * (1.0 / TAU);
        if u < 0.0 {
            u += 1.0;
        }
        Vec2::new(u, fastmath::acos(d.y.clamp(-1.0, 1.0)) * (1.0 / PI))
    }

    /// Radiance arriving from world direction `d` (unit; pointing away from the scene).
    #[inline]
    pub fn eval(&self, d: Vec3) -> Rgb {
        let uv = Self::uv_of(self.to_local * d);
        self.lookup(uv.x, uv.y)
    }

    /// Radiance from world direction `d` and the solid-angle density with which
    /// [`EnvMap::sample`] picks it, sharing the coordinate computation.
    #[inline]
    pub fn eval_pdf(&self, d: Vec3) -> (Rgb, f32) {
        let l = self.to_local * d;
        let uv = Self::uv_of(l);
        let (texel, density) = self.lookup_density(uv.x, uv.y);
        let radiance = texel * self.scale;
        let sin_theta = (l.x * l.x + l.z * l.z).sqrt();
        if sin_theta <= 1e-7 {
            return (radiance, 0.0);
        }
        (radiance, density / (2.0 * PI * PI * sin_theta))
    }

    /// The corner texels of `LANES` cells (columns `ix`, rows `iy`) and the sines of their
    /// top and bottom pixel rows: `([top-left, top-right, bottom-left, bottom-right],
    /// sin top, sin bottom)`. The cells are clamped to the grid first (a no-op for the
    /// cells the callers compute), so the reads need no bounds check per lane.
    #[inline(always)]
    fn cells_xn(&self, ix: u32xn, iy: u32xn) -> ([RgbxN; 4], f32xn, f32xn) {
        let (w, h) = (self.width, self.height);
        let ix = ix.min(u32xn::splat(w as u32 - 1));
        let iy = iy.min(u32xn::splat(h as u32 - 2));
        let k = (iy * u32xn::splat(w as u32 + 1) + ix).to_array();
        let iy = iy.to_array();
        let (d, rows) = (&self.data, &self.sin_row);
        assert!(w >= 2 && h >= 3 && d.len() == 3 * (w + 1) * h && rows.len() == h);
        // SAFETY: with ix <= w - 1 and iy <= h - 2 (clamped above), the last float read,
        // that of the bottom-right texel k + w + 2 <= (h - 1)(w + 1) + w, is within the
        // h (w + 1) texels of `data` (asserted).
        let (tl, tr) = unsafe { Self::pixel_pairs(d, &k, 0) };
        let (bl, br) = unsafe { Self::pixel_pairs(d, &k, 3 * (w + 1)) };
        // SAFETY: iy + 1 <= h - 1 < rows.len() (clamped above, asserted).
        let sine = |j: usize| {
            f32xn::new(simd::lanes(|i| unsafe {
                *rows.get_unchecked(iy[i] as usize + j)
            }))
        };
        ([tl, tr, bl, br], sine(0), sine(1))
    }

    /// The texels `k[i]` and `k[i] + 1` of `data`, offset by `offset` floats, in lane i:
    /// a pixel pair is six floats, r0 g0 b0 r1 g1 b1, whose first four and last four
    /// (overlapping) are read as two 4-float transposes.
    ///
    /// # Safety
    /// `3 k[i] + offset + 6 <= data.len()` in every lane.
    #[inline(always)]
    unsafe fn pixel_pairs(data: &[f32], k: &[u32; LANES], offset: usize) -> (RgbxN, RgbxN) {
        let p = simd::lanes(|i| {
            let s = 3 * k[i] as usize + offset;
            // SAFETY: in bounds by the caller's contract.
            let f = |j: usize| unsafe { *data.get_unchecked(s + j) };
            ([f(0), f(1), f(2), f(3)], [f(2), f(3), f(4), f(5)])
        });
        let a = simd::transpose4xn(&simd::lanes(|i| p[i].0));
        let b = simd::transpose4xn(&simd::lanes(|i| p[i].1));
        (RgbxN::new(a[0], a[1], a[2]), RgbxN::new(a[3], b[2], b[3]))
    }

    /// [`EnvMap::blend`] in SIMD lanes, with the same operations: radiance (without
    /// `scale`) and density at (`fx`, `fy`) in cells with corner texels `t`, whose rows
    /// have sin(theta) `s_top` and `s_bottom`.
    #[inline(always)]
    fn blend_xn(
        &self,
        t: &[RgbxN; 4],
        s_top: f32xn,
        s_bottom: f32xn,
        fx: f32xn,
        fy: f32xn,
    ) -> (RgbxN, f32xn) {
        let one = f32xn::splat(1.0);
        let zero = f32xn::splat(0.0);
        let top = t[0] * (one - fx) + t[1] * fx;
        let bottom = t[2] * (one - fx) + t[3] * fx;
        let texel = top * (one - fy) + bottom * fy;
        let inv_mean = f32xn::splat(self.inv_mean);
        let density = if self.inv_mean == 0.0 {
            one
        } else if self.offset > 0.0 {
            let c = self.corner_weights_xn(t, s_top, s_bottom);
            ((one - fy) * (c[0] * (one - fx) + c[1] * fx) + fy * (c[2] * (one - fx) + c[3] * fx))
                * inv_mean
        } else {
            ((one - fy) * top.luminance().max(zero) * s_top
                + fy * bottom.luminance().max(zero) * s_bottom)
                * inv_mean
        };
        (texel, density)
    }

    /// [`EnvMap::corner_weights`] in SIMD lanes.
    #[inline(always)]
    fn corner_weights_xn(&self, t: &[RgbxN; 4], s_top: f32xn, s_bottom: f32xn) -> [f32xn; 4] {
        let (offset, zero) = (f32xn::splat(self.offset), f32xn::splat(0.0));
        let w = |c: &RgbxN, s: f32xn| (c.luminance() - offset).max(zero) * s;
        [
            w(&t[0], s_top),
            w(&t[1], s_top),
            w(&t[2], s_bottom),
            w(&t[3], s_bottom),
        ]
    }

    /// [`EnvMap::eval_pdf`] of many directions, `out[i]` for `dirs[i]`, bit for bit the
    /// same: a lane vector at a time in SIMD lanes (`wide`'s AVX vectors), with the lane forms of
    /// the same functions ([`fastmath::xn`]), so that the independent texel reads of `LANES`
    /// lookups overlap and the arithmetic runs once per `LANES` directions.
    pub fn eval_pdf_many(&self, dirs: &[Vec3], out: &mut [(Rgb, f32)]) {
        assert_eq!(dirs.len(), out.len());
        let (w, h) = (self.width, self.height);
        let zero = f32xn::splat(0.0);
        for (dc, oc) in dirs.chunks(LANES).zip(out.chunks_mut(LANES)) {
            let n = dc.len();
            let d = simd::lanes(|i| dc[i.min(n - 1)]);
            let [dx, dy, dz] = simd::vec3s(&d);
            let [lx, ly, lz] = mat3_mul_xn(&self.to_local, dx, dy, dz);
            // Texture coordinates ([`EnvMap::uv_of`]).
            let u = xn::atan2(lx, -lz) * f32xn::splat(1.0 / TAU);
            let u = simd::sel(u.simd_lt(zero), u + f32xn::splat(1.0), u);
            let v = xn::acos(simd::clamp(ly, -1.0, 1.0)) * f32xn::splat(1.0 / PI);
            let st = (lx * lx + lz * lz).sqrt();
            // The bilinear cell ([`EnvMap::texel_cell`]).
            let x = u - f32xn::splat(0.5 / w as f32);
            let x = (x - x.floor()) * f32xn::splat(w as f32);
            let y = (v - v.floor()) * f32xn::splat((h - 1) as f32);
            let ix = x
                .trunc_int()
                .max(i32xn::splat(0))
                .min(i32xn::splat(w as i32 - 1));
            let iy = y
                .trunc_int()
                .max(i32xn::splat(0))
                .min(i32xn::splat(h as i32 - 2));
            let fx = x - lobe_materials::simd::float_of(ix);
            let fy = y - lobe_materials::simd::float_of(iy);
            let (t, s_top, s_bottom) = self.cells_xn(to_u32(ix), to_u32(iy));
            let (texel, density) = self.blend_xn(&t, s_top, s_bottom, fx, fy);
            let radiance = texel * f32xn::splat(self.scale);
            let pdf = simd::sel(
                st.simd_le(f32xn::splat(1e-7)),
                zero,
                density / (f32xn::splat(2.0 * PI * PI) * st),
            )
            .to_array();
            for (i, o) in oc.iter_mut().enumerate() {
                *o = (radiance.lane(i), pdf[i]);
            }
        }
    }

    /// [`EnvMap::sample`] of many points, bit for bit the same, a lane vector at a time in SIMD
    /// lanes as [`EnvMap::eval_pdf_many`]: for `us[i]`, the direction `wi[i]`, radiance
    /// `li[i]` and pdf `pdf[i]`, or a pdf of 0 (and zero direction and radiance) where
    /// `sample` gives None.
    pub fn sample_many(&self, us: &[Vec2], wi: &mut [Vec3], li: &mut [Rgb], pdf: &mut [f32]) {
        assert!(us.len() == wi.len() && us.len() == li.len() && us.len() == pdf.len());
        let (w, h) = (self.width as f32, (self.height - 1) as f32);
        let zero = f32xn::splat(0.0);
        let one_minus_eps = f32xn::splat(1.0 - f32::EPSILON / 2.0);
        // Two lane vectors of points at a time: two groups descend the hierarchy side by side
        // (two independent dependency chains the core overlaps; three or four groups
        // measured no faster), then each goes on alone.
        const GROUPS: usize = 2;
        for (c2, uc2) in us.chunks(LANES * GROUPS).enumerate() {
            let group = |uc: &[Vec2]| simd::vec2s(&simd::padded(&uc[..uc.len().min(LANES)]));
            let [x0, y0] = group(uc2);
            let cells = match uc2.get(LANES..) {
                Some(rest) if !rest.is_empty() => {
                    let [x1, y1] = group(rest);
                    self.cells.sample_groups([x0, x1], [y0, y1])
                }
                // A lone group descends alone.
                _ => {
                    let [c] = self.cells.sample_groups([x0], [y0]);
                    [c, c]
                }
            };
            for (g, uc) in uc2.chunks(LANES).enumerate() {
                let n = uc.len();
                let (cx, cy, rx, ry) = cells[g];
                let (t, s_top, s_bottom) = self.cells_xn(cx, cy);
                let (ix, iy) = (cx.to_array(), cy.to_array());
                // Within the cell, the bilinear density of the corner weights.
                let (fx, fy) = if self.inv_mean == 0.0 {
                    (rx, ry)
                } else {
                    let cw = self.corner_weights_xn(&t, s_top, s_bottom);
                    bilinear(rx, ry, cw)
                };
                let cxf = f32xn::new(simd::lanes(|i| ix[i] as f32));
                let cyf = f32xn::new(simd::lanes(|i| iy[i] as f32));
                let ax = ((cxf + fx) / f32xn::splat(w)).min(one_minus_eps);
                let vv = ((cyf + fy) / f32xn::splat(h)).min(one_minus_eps);
                let x = ax + f32xn::splat(0.5 / w);
                let uu = simd::sel(x.simd_ge(f32xn::splat(1.0)), x - f32xn::splat(1.0), x);
                let (st, ct) = xn::sin_cos_moderate(vv * f32xn::splat(PI));
                let (sp, cp) = xn::sin_cos_moderate(uu * f32xn::splat(TAU));
                let (texel, pdf_ab) = self.blend_xn(&t, s_top, s_bottom, fx, fy);
                let valid = st.simd_gt(f32xn::splat(1e-7)) & pdf_ab.simd_gt(zero);
                let [dx, dy, dz] = mat3_mul_xn(&self.to_world, st * sp, ct, -(st * cp));
                let radiance = texel * f32xn::splat(self.scale);
                let p = pdf_ab / (f32xn::splat(2.0 * PI * PI) * st);
                // Invalid lanes get a zero direction, radiance and pdf.
                let keep = |v: f32xn| simd::sel(valid, v, zero);
                let [dx, dy, dz] = simd::arrays3([keep(dx), keep(dy), keep(dz)]);
                let [r, gr, b] = simd::arrays3([radiance.r, radiance.g, radiance.b].map(keep));
                let p = keep(p).to_array();
                let base = LANES * (GROUPS * c2 + g);
                for i in 0..n {
                    let o = base + i;
                    wi[o] = Vec3::new(dx[i], dy[i], dz[i]);
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
        // Within the cell, the bilinear density of the corner luminances (uniform for a
        // black map): the radiance over the density is then smooth, not stepped per cell.
        let f = if self.inv_mean == 0.0 {
            r
        } else {
            square_to_bilinear(
                r,
                Self::corner_weights(&self.data, &self.sin_row, self.offset, self.width, ix, iy),
            )
        };
        let ab = Vec2::new(
            ((ix as f32 + f.x) / self.width as f32).min(1.0 - f32::EPSILON / 2.0),
            ((iy as f32 + f.y) / (self.height - 1) as f32).min(1.0 - f32::EPSILON / 2.0),
        );
        let mut uu = ab.x + 0.5 / self.width as f32;
        if uu >= 1.0 {
            uu -= 1.0;
        }
        let theta = ab.y * PI;
        let phi = uu * TAU;
        let (st, ct) = fastmath::sin_cos(theta);
        let (sp, cp) = fastmath::sin_cos(phi);
        if st <= 1e-7 {
            return None;
        }
        // Radiance and density at the sampled point of the cell: the lookup `eval_pdf`
        // makes at the sampled direction, without finding the cell again.
        let (texel, pdf_ab) = self.blend((iy * (self.width + 1) + ix, iy, f.x, f.y));
        if !(pdf_ab > 0.0) {
            return None;
        }
        let local = Vec3::new(st * sp, ct, -st * cp);
        let pdf = pdf_ab / (2.0 * PI * PI * st);
        Some((self.to_world * local, texel * self.scale, pdf))
    }
}

/// Pixel `k` of flat r, g, b data.
#[inline(always)]
fn texel(d: &[f32], k: usize) -> Rgb {
    let p = &d[3 * k..3 * k + 3];
    Rgb::new(p[0], p[1], p[2])
}

/// `m * (x, y, z)` in SIMD lanes, with glam's `Mat3 * Vec3` operations.
#[inline(always)]
fn mat3_mul_xn(m: &Mat3, x: f32xn, y: f32xn, z: f32xn) -> [f32xn; 3] {
    let row = |c: usize| {
        f32xn::splat(m.x_axis[c]) * x
            + f32xn::splat(m.y_axis[c]) * y
            + f32xn::splat(m.z_axis[c]) * z
    };
    [row(0), row(1), row(2)]
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

/// Non-negative lanes as unsigned ones (the same bits).
#[inline(always)]
fn to_u32(v: i32xn) -> u32xn {
    u32xn::new(v.to_array().map(|x| x as u32))
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
