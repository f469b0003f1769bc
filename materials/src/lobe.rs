//! The specular-lobe interface: the `lobe_k(p)` of the study's
//! `M = diffuse_rgb * Lambert + sum_k specular_rgb_k * lobe_k(p)` (Ngan et al. 2005, sec. 3.1).
//!
//! A lobe is a function of the two directions, shared by the three colour channels in
//! every model but He et al.'s, whose wave-optics terms depend on the wavelength of each
//! channel; so a lobe value is an RGB triple (equal channels for the others). A model writes
//! its value, sampler density and sampler once over [`Num`] ([`GenericLobe`]) and gets the
//! f32 and lane entry points for rendering and the f64 value for fitting through
//! [`impl_lobe_forms!`]; a model whose rendered form is its own (He et al.'s, from f32
//! tables) writes it once over [`Single`] ([`SingleLobe`], `impl_lobe_forms!(single)`). A
//! model with only a generic value uses [`impl_lobe_eval!`].
//! Directions follow [`crate::bsdf`]: local frame, both pointing away from the surface.

use crate::columns::{Vec2Cols, Vec3Cols, Vec3ColsMut};
use crate::math::{Num, Real, Single, V3, gt, is_finite, le, maximum, select, sin_cos, sqrt};
use crate::simd::{LANES, MaskN, RgbxN, Vec3xN, f32xn, lanes, mask_bits, mask_from_bools, padded};
use crate::{Flags, Rgb};
use glam::{DVec3, Vec2, Vec3};

pub trait Lobe: Send + Sync + std::fmt::Debug {
    /// Registry name of the model.
    fn model(&self) -> &'static str;
    /// Lobe value in 1/sr (no cosine) per channel, zero when either direction is below
    /// the surface.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb;
    /// The same value in double precision (for fitting).
    fn eval_f64(&self, wo: DVec3, wi: DVec3) -> [f64; 3];
    /// `eval_f64` of many (wo, wi) pairs into `out` (the fitting inner loop). Models with
    /// costly factors that depend only on the two elevation angles (He et al.'s shadowing
    /// and effective roughness) override it to share those factors between consecutive
    /// pairs of equal elevations, as the bins of one (theta_i, theta_o) row are.
    fn eval_f64_many(&self, pairs: &[(DVec3, DVec3)], out: &mut [[f64; 3]]) {
        for (o, &(wo, wi)) in out.iter_mut().zip(pairs) {
            *o = self.eval_f64(wo, wi);
        }
    }
    /// Importance-samples `wi` for `wo` from a 2D sample `u` and a 1D sample `uc` (for
    /// models that first choose among facets or proposals); None when the sample falls
    /// below the surface.
    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<Vec3>;
    /// Solid-angle density of `sample`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// [`Lobe::eval`] and [`Lobe::pdf`] of `LANES` pairs (lane k: `wo.lane(k)`,
    /// `wi.lane(k)`), each lane bit for bit the scalar calls: the batched calls of the
    /// materials made of lobes ([`crate::composite::Composite`]). The default calls the
    /// scalar forms lane by lane; a [`GenericLobe`] or [`SingleLobe`] gets it from
    /// [`impl_lobe_forms!`].
    fn eval_pdf_xn(&self, wo: Vec3xN, wi: Vec3xN) -> (RgbxN, f32xn) {
        let (o, i) = (wo.to_array(), wi.to_array());
        let f = lanes(|k| self.eval(o[k], i[k]));
        (
            RgbxN::from_array(&f),
            f32xn::new(lanes(|k| self.pdf(o[k], i[k]))),
        )
    }
    /// The value of [`Lobe::eval_pdf_xn`] alone (bit for bit), for batched calls that need
    /// no density ([`crate::Bsdf::eval_many`]). The default drops the density; a
    /// [`GenericLobe`] or [`SingleLobe`] evaluates its value only.
    fn eval_xn(&self, wo: Vec3xN, wi: Vec3xN) -> RgbxN {
        self.eval_pdf_xn(wo, wi).0
    }
    /// [`Lobe::sample`] of `LANES` queries (lane k: `wo.lane(k)`, `u[0]` and `u[1]`'s lane
    /// k, `uc`'s lane k), each lane bit for bit the scalar call: the directions, and the
    /// mask of the lanes that drew one (the scalar call's `Some`; elsewhere the direction
    /// means nothing). The batched sampling of [`crate::composite::Composite`]. The default
    /// samples lane by lane; a [`GenericLobe`] or [`SingleLobe`] gets it from
    /// [`impl_lobe_forms!`].
    fn sample_xn(&self, wo: Vec3xN, u: [f32xn; 2], uc: f32xn) -> (Vec3xN, MaskN) {
        let (o, [ux, uy], uc) = (wo.to_array(), u.map(|c| c.to_array()), uc.to_array());
        let s = lanes(|k| self.sample(o[k], Vec2::new(ux[k], uy[k]), uc[k]));
        (
            Vec3xN::from_array(&lanes(|k| s[k].unwrap_or(Vec3::ZERO))),
            mask_from_bools(lanes(|k| s[k].is_some())),
        )
    }
    /// [`Lobe::sample`] of every query of a batch (direction `wi` k and `drawn[k]` for
    /// `wo` k, `u[k]`, `uc[k]`; the directions as columns), each bit for bit the scalar
    /// call: the queries of a [`crate::composite::Composite`] block that chose this lobe.
    /// The default calls [`Lobe::sample_xn`] a lane vector at a time; lobes whose sampler
    /// is a long dependency chain override it to overlap two lane vectors.
    fn sample_batch(
        &self,
        wo: Vec3Cols,
        u: Vec2Cols,
        uc: &[f32],
        mut wi: Vec3ColsMut,
        drawn: &mut [bool],
    ) {
        let n = drawn.len();
        assert!(wo.len() == n && u.len() == n && uc.len() == n && wi.len() == n);
        for first in (0..n).step_by(LANES) {
            let r = first..(first + LANES).min(n);
            let drawn_lanes =
                self.sample_xn(wo.load(first), u.load(first), f32xn::new(padded(&uc[r])));
            store_drawn(drawn_lanes, first, &mut wi, drawn);
        }
    }
    fn flags(&self) -> Flags;
    /// Bytes this lobe holds (its tables, if any).
    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self)
    }
}

/// Writes a lane vector of sampled directions and the mask of lanes that drew one
/// ([`Lobe::sample_xn`]'s) to elements `first..` of `wi` and `drawn` (the lanes that fit).
#[inline(always)]
pub fn store_drawn(
    (d, ok): (Vec3xN, MaskN),
    first: usize,
    wi: &mut Vec3ColsMut,
    drawn: &mut [bool],
) {
    wi.store(first, d);
    let ok = mask_bits(ok);
    let n = (drawn.len() - first).min(LANES);
    for (lane, flag) in drawn[first..first + n].iter_mut().enumerate() {
        *flag = ok >> lane & 1 != 0;
    }
}

/// Implements `Lobe::eval` and `Lobe::eval_f64` from an inherent
/// `fn value<T: Real>(&self, wo: V3<T>, wi: V3<T>) -> T` shared by the three channels.
#[macro_export]
macro_rules! impl_lobe_eval {
    () => {
        #[inline]
        fn eval(&self, wo: $crate::glam::Vec3, wi: $crate::glam::Vec3) -> $crate::Rgb {
            $crate::Rgb::splat(self.value::<f32>(wo.into(), wi.into()))
        }
        #[inline]
        fn eval_f64(&self, wo: $crate::glam::DVec3, wi: $crate::glam::DVec3) -> [f64; 3] {
            [self.value::<f64>(wo.into(), wi.into()); 3]
        }
    };
}

/// A lobe written once over [`Num`]: its value, the density of its sampler and the
/// sampler, each one generic function that [`impl_lobe_forms!`] instantiates for the
/// scalar entry points of [`Lobe`] (f32, and f64 for the value) and for its lane entry
/// points ([`f32xn`]), which therefore agree bit for bit. Directions in the local frame.
pub trait GenericLobe {
    /// The lobe value (1/sr, no cosine) shared by the three channels, zero below the
    /// surface.
    fn value<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T;
    /// Solid-angle density of [`GenericLobe::draw`]'s direction, zero where it draws none.
    fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T;
    /// A direction for `wo` from a 2D uniform (`ux`, `uy`) and a 1D uniform `uc`, and
    /// where it is one (above the surface, for `wo` above it).
    fn draw<T: Num>(&self, wo: V3<T>, ux: T, uy: T, uc: T) -> (V3<T>, T::Mask);
    /// The value per channel (the same in each): the form [`SingleLobe::channels`] has.
    #[inline(always)]
    fn channels<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> [T; 3] {
        [self.value(wo, wi); 3]
    }
    /// [`GenericLobe::channels`] and [`GenericLobe::density`].
    #[inline(always)]
    fn channels_density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> ([T; 3], T) {
        (self.channels(wo, wi), self.density(wo, wi))
    }
}

/// A lobe whose rendered forms are written once over [`Single`] (f32 and lanes) with a
/// value per channel (He et al.'s wave-optics terms depend on each channel's wavelength),
/// and whose f64 value (for fitting) is its own: `impl_lobe_forms!(single)` instantiates
/// its f32 and lane entry points of [`Lobe`], which agree bit for bit, and the model
/// writes `eval_f64`.
pub trait SingleLobe {
    /// The lobe value (1/sr, no cosine) per channel, zero below the surface.
    fn channels<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> [T; 3];
    /// [`SingleLobe::channels`] and [`SingleLobe::density`] (a model may share their
    /// common terms), each bit for bit its own call.
    fn channels_density<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> ([T; 3], T) {
        (self.channels(wo, wi), self.density(wo, wi))
    }
    /// Solid-angle density of [`SingleLobe::draw`]'s direction, zero where it draws none.
    fn density<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> T;
    /// A direction for `wo` from a 2D uniform (`ux`, `uy`) and a 1D uniform `uc`, and
    /// where it is one.
    fn draw<T: Single>(&self, wo: V3<T>, ux: T, uy: T, uc: T) -> (V3<T>, T::Mask);
}

/// Implements [`Lobe`]'s entry points inside an `impl Lobe` block from the forms written
/// once: `impl_lobe_forms!()` for a [`GenericLobe`] (`eval`, `eval_f64`, `pdf`, `sample`,
/// `eval_pdf_xn`, `eval_xn`, `sample_xn`), `impl_lobe_forms!(single)` for a
/// [`SingleLobe`] (all but `eval_f64`).
#[macro_export]
macro_rules! impl_lobe_forms {
    () => {
        #[inline]
        fn eval_f64(&self, wo: $crate::glam::DVec3, wi: $crate::glam::DVec3) -> [f64; 3] {
            <Self as $crate::lobe::GenericLobe>::channels::<f64>(self, wo.into(), wi.into())
        }
        $crate::impl_lobe_forms!(@rendered $crate::lobe::GenericLobe);
    };
    (single) => {
        $crate::impl_lobe_forms!(@rendered $crate::lobe::SingleLobe);
    };
    (@rendered $form:path) => {
        #[inline]
        fn eval(&self, wo: $crate::glam::Vec3, wi: $crate::glam::Vec3) -> $crate::Rgb {
            $crate::Rgb::from(<Self as $form>::channels::<f32>(self, wo.into(), wi.into()))
        }
        #[inline]
        fn pdf(&self, wo: $crate::glam::Vec3, wi: $crate::glam::Vec3) -> f32 {
            <Self as $form>::density::<f32>(self, wo.into(), wi.into())
        }
        #[inline]
        fn sample(
            &self,
            wo: $crate::glam::Vec3,
            u: $crate::glam::Vec2,
            uc: f32,
        ) -> Option<$crate::glam::Vec3> {
            let (wi, ok) = <Self as $form>::draw::<f32>(self, wo.into(), u.x, u.y, uc);
            ok.then(|| wi.into())
        }
        #[inline]
        fn eval_pdf_xn(
            &self,
            wo: $crate::simd::Vec3xN,
            wi: $crate::simd::Vec3xN,
        ) -> ($crate::simd::RgbxN, $crate::simd::f32xn) {
            let ([r, g, b], p) = <Self as $form>::channels_density(self, wo, wi);
            ($crate::simd::RgbxN::new(r, g, b), p)
        }
        #[inline]
        fn eval_xn(
            &self,
            wo: $crate::simd::Vec3xN,
            wi: $crate::simd::Vec3xN,
        ) -> $crate::simd::RgbxN {
            let [r, g, b] = <Self as $form>::channels(self, wo, wi);
            $crate::simd::RgbxN::new(r, g, b)
        }
        #[inline]
        fn sample_xn(
            &self,
            wo: $crate::simd::Vec3xN,
            u: [$crate::simd::f32xn; 2],
            uc: $crate::simd::f32xn,
        ) -> ($crate::simd::Vec3xN, $crate::simd::MaskN) {
            <Self as $form>::draw(self, wo, u[0], u[1], uc)
        }
    };
}

/// The mirror of `wo` about the unit vector `h`, 2 (wo . h) h - wo, and where it is a
/// sample: `wo` and it above the surface and `wo . h` positive (Walter et al. 2007,
/// eq. 14, the reflection of a sampled half vector).
#[inline(always)]
pub fn reflect_above<T: Num>(wo: V3<T>, h: V3<T>) -> (V3<T>, T::Mask) {
    let zero = T::of(0.0);
    let d = wo.dot(h);
    let wi = h * (T::of(2.0) * d) - wo;
    (wi, gt(wo.z, zero) & gt(d, zero) & gt(wi.z, zero))
}

/// A half vector from its elevation cosine and the azimuth `2 pi ux` (`ux` in [0, 1)).
#[inline(always)]
pub fn half_from<T: Num>(cos_t: T, ux: T) -> V3<T> {
    let sin_t = sqrt(maximum(T::of(1.0) - cos_t * cos_t, T::of(0.0)));
    let (s, c) = sin_cos(T::of(2.0 * std::f32::consts::PI as f64) * ux);
    V3::new(sin_t * c, sin_t * s, cos_t)
}

/// The density of `wi` = `wo` reflected about a half vector drawn with density `pdf_h`
/// (solid angle of h): pdf_h(h) / (4 wo.h) ([`half_to_incident_pdf`]), zero below the
/// surface and where `wo` and `wi` have no half vector.
#[inline(always)]
pub fn reflected_pdf<T: Num>(wo: V3<T>, wi: V3<T>, pdf_h: impl Fn(V3<T>) -> T) -> T {
    let (h, has_half) = half_where(wo, wi);
    let ok = both_above(wo, wi) & has_half;
    select(ok, half_to_incident_pdf(pdf_h(h), wo.dot(h)), T::of(0.0))
}

/// Converts a half-vector density to the density of the reflected direction:
/// p(wi) = p(h) / (4 |wo . h|) (Walter et al. 2007, eq. 14); zero where `wo . h <= 0`.
#[inline(always)]
pub fn half_to_incident_pdf<T: Num>(pdf_h: T, wo_dot_h: T) -> T {
    let zero = T::of(0.0);
    select(le(wo_dot_h, zero), zero, pdf_h / (T::of(4.0) * wo_dot_h))
}

/// Cosines of the angles of a pair of upper-hemisphere directions, or None below.
#[inline(always)]
pub fn above<T: Real>(wo: V3<T>, wi: V3<T>) -> Option<(T, T)> {
    (wo.z > T::zero() && wi.z > T::zero()).then_some((wo.z, wi.z))
}

/// Where both directions are above the surface (per lane): [`above`]'s condition.
#[inline(always)]
pub fn both_above<T: Num>(wo: V3<T>, wi: V3<T>) -> T::Mask {
    let zero = T::of(0.0);
    gt(wo.z, zero) & gt(wi.z, zero)
}

/// The unit half vector of `wo` and `wi`, and where it exists (a positive, finite squared
/// length): [`crate::math::half`] with its `None` as a mask.
#[inline(always)]
pub fn half_where<T: Num>(wo: V3<T>, wi: V3<T>) -> (V3<T>, T::Mask) {
    let h = wo + wi;
    let l2 = h.length_squared();
    let ok = gt(l2, T::of(0.0)) & is_finite(l2);
    (h * (T::of(1.0) / sqrt(l2)), ok)
}
