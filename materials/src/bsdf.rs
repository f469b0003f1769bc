//! The BRDF plugin interface and the linear-RGB spectrum type.
//!
//! Conventions (pbrt-v4's, see DESIGN.md): directions are unit vectors in the local
//! shading frame, `z` is the surface normal, and both `wo` (toward the viewer) and `wi`
//! (toward the light) point away from the surface. Values are linear Rec.709 RGB.
//! `eval` returns f_r in 1/sr *without* the cosine factor; `sample` returns the weight
//! `f_r * cos(theta_i) / pdf` with the pdf in solid-angle measure. A BRDF is one-sided:
//! when either direction is below the surface it evaluates to zero, as Mitsuba 3's BSDFs do.

use crate::columns::{Vec2Cols, Vec3Cols, Vec3ColsMut, Vec3s};
use crate::math::{Num, gt, is_finite};
use glam::{Vec2, Vec3};
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Range, Sub};

/// Linear Rec.709 RGB triple.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb {
    pub r: f32,
    pub g: f32,
    pub b: f32,
}

impl Rgb {
    pub const ZERO: Rgb = Rgb::splat(0.0);
    pub const ONE: Rgb = Rgb::splat(1.0);

    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Self { r, g, b }
    }
    pub const fn splat(v: f32) -> Self {
        Self { r: v, g: v, b: v }
    }
    pub fn to_array(self) -> [f32; 3] {
        [self.r, self.g, self.b]
    }
    pub fn max_component(self) -> f32 {
        self.r.max(self.g).max(self.b)
    }
    pub fn min_component(self) -> f32 {
        self.r.min(self.g).min(self.b)
    }
    /// Luminance with Rec.709 / sRGB primaries (the weights Mitsuba 3 uses).
    pub fn luminance(self) -> f32 {
        0.212671 * self.r + 0.715160 * self.g + 0.072169 * self.b
    }
    /// All three components finite (tested together, without a branch per component).
    #[inline]
    pub fn is_finite(self) -> bool {
        self.r.is_finite() & self.g.is_finite() & self.b.is_finite()
    }
    /// All three components zero (tested together, without a branch per component).
    #[inline]
    pub fn is_black(self) -> bool {
        (self.r == 0.0) & (self.g == 0.0) & (self.b == 0.0)
    }
    pub fn map(self, f: impl Fn(f32) -> f32) -> Rgb {
        Rgb::new(f(self.r), f(self.g), f(self.b))
    }
}

impl From<[f32; 3]> for Rgb {
    fn from(a: [f32; 3]) -> Self {
        Rgb::new(a[0], a[1], a[2])
    }
}

impl Add for Rgb {
    type Output = Rgb;
    fn add(self, o: Rgb) -> Rgb {
        Rgb::new(self.r + o.r, self.g + o.g, self.b + o.b)
    }
}
impl AddAssign for Rgb {
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}
impl Sub for Rgb {
    type Output = Rgb;
    fn sub(self, o: Rgb) -> Rgb {
        Rgb::new(self.r - o.r, self.g - o.g, self.b - o.b)
    }
}
impl Mul for Rgb {
    type Output = Rgb;
    fn mul(self, o: Rgb) -> Rgb {
        Rgb::new(self.r * o.r, self.g * o.g, self.b * o.b)
    }
}
impl MulAssign for Rgb {
    fn mul_assign(&mut self, o: Rgb) {
        *self = *self * o;
    }
}
impl Mul<f32> for Rgb {
    type Output = Rgb;
    fn mul(self, s: f32) -> Rgb {
        Rgb::new(self.r * s, self.g * s, self.b * s)
    }
}
impl MulAssign<f32> for Rgb {
    fn mul_assign(&mut self, s: f32) {
        *self = *self * s;
    }
}
impl Mul<Rgb> for f32 {
    type Output = Rgb;
    fn mul(self, c: Rgb) -> Rgb {
        c * self
    }
}
impl Div<f32> for Rgb {
    type Output = Rgb;
    fn div(self, s: f32) -> Rgb {
        Rgb::new(self.r / s, self.g / s, self.b / s)
    }
}

/// Properties of a BRDF that tests and integrators rely on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags(u32);

impl Flags {
    pub const NONE: Flags = Flags(0);
    /// f depends on the azimuths only through their difference.
    pub const ISOTROPIC: Flags = Flags(1);
    /// f(wo, wi) = f(wi, wo).
    pub const RECIPROCAL: Flags = Flags(2);
    /// The directional albedo never exceeds 1 for legal parameters.
    pub const ENERGY_BOUNDED: Flags = Flags(4);
    /// Has a diffuse (Lambertian-like) component.
    pub const DIFFUSE: Flags = Flags(8);
    /// Has a glossy component.
    pub const GLOSSY: Flags = Flags(16);

    pub const fn union(self, o: Flags) -> Flags {
        Flags(self.0 | o.0)
    }
    pub const fn contains(self, o: Flags) -> bool {
        self.0 & o.0 == o.0
    }
    pub const fn bits(self) -> u32 {
        self.0
    }
}

impl std::ops::BitOr for Flags {
    type Output = Flags;
    fn bitor(self, o: Flags) -> Flags {
        self.union(o)
    }
}

/// The result of importance sampling a BRDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled direction toward the light, local frame, unit length.
    pub wi: Vec3,
    /// `f_r(wo, wi) * cos(theta_i) / pdf`.
    pub weight: Rgb,
    /// Solid-angle density of `wi`.
    pub pdf: f32,
}

impl BsdfSample {
    /// The sample of a drawn `wi`: None below the surface, where the density `pdf()` is
    /// not positive, or where the weight `f() cos(theta_i) / pdf` is not finite (a
    /// direction drawn with a subnormal density: cos / pdf overflows); otherwise that
    /// weight (both evaluated only when needed; [`BsdfSample::weight_where`]'s rule).
    pub fn finish(wi: Vec3, pdf: impl FnOnce() -> f32, f: impl FnOnce() -> Rgb) -> Option<Self> {
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = pdf();
        if !(pdf > 0.0) {
            return None;
        }
        let (weight, keep) = Self::weight_where(wi.z, pdf, f().to_array());
        keep.then(|| BsdfSample {
            wi,
            weight: Rgb::from(weight),
            pdf,
        })
    }

    /// The weight `f cos(theta_i) / pdf` of a drawn direction (cosine `wi_z`, density
    /// `pdf`, value `f`) and where it makes a sample: above the surface, a positive density
    /// and a finite weight. One rule for one sample and for lanes (the tests as one mask
    /// instead of a branch per lane, which batched sampling would mispredict).
    #[inline(always)]
    pub fn weight_where<T: Num>(wi_z: T, pdf: T, f: [T; 3]) -> ([T; 3], T::Mask) {
        let scale = wi_z / pdf;
        let weight = f.map(|c| c * scale);
        let zero = T::of(0.0);
        let finite = is_finite(weight[0]) & is_finite(weight[1]) & is_finite(weight[2]);
        (weight, gt(wi_z, zero) & gt(pdf, zero) & finite)
    }
}

/// The samples of a batch ([`Bsdf::sample_many`]'s output) as columns, as the wavefront's
/// other queues hold theirs: entry k is "no sample" where its density is 0 (or negative),
/// and a sample otherwise (a sample's density is positive, or NaN: [`Bsdf::sample`]).
#[derive(Clone, Debug, Default)]
pub struct BsdfSamples {
    wi: Vec3s,
    weight: Vec<Rgb>,
    pdf: Vec<f32>,
}

impl BsdfSamples {
    /// `n` entries, all "no sample".
    pub fn new(n: usize) -> Self {
        let mut s = Self::default();
        s.reset(n);
        s
    }

    /// Makes the columns `n` entries long, all "no sample".
    pub fn reset(&mut self, n: usize) {
        self.wi.clear();
        self.wi.resize(n);
        self.weight.clear();
        self.weight.resize(n, Rgb::ZERO);
        self.pdf.clear();
        self.pdf.resize(n, 0.0);
    }

    pub fn len(&self) -> usize {
        self.pdf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pdf.is_empty()
    }

    /// Entry `k`: its sample, or None.
    #[inline]
    pub fn get(&self, k: usize) -> Option<BsdfSample> {
        (!(self.pdf[k] <= 0.0)).then(|| BsdfSample {
            wi: self.wi.get(k),
            weight: self.weight[k],
            pdf: self.pdf[k],
        })
    }

    /// The sampled directions (whatever the buffer held where there is no sample).
    pub fn wi(&self) -> Vec3Cols<'_> {
        self.wi.cols()
    }

    /// Every entry in order.
    pub fn iter(&self) -> impl Iterator<Item = Option<BsdfSample>> + '_ {
        (0..self.len()).map(|k| self.get(k))
    }

    /// The columns to write ([`Bsdf::sample_many`]).
    pub fn cols_mut(&mut self) -> BsdfSamplesMut<'_> {
        BsdfSamplesMut {
            wi: self.wi.cols_mut(),
            weight: &mut self.weight,
            pdf: &mut self.pdf,
        }
    }
}

/// [`BsdfSamples`]' columns (or a range of them), borrowed to be written.
pub struct BsdfSamplesMut<'a> {
    wi: Vec3ColsMut<'a>,
    weight: &'a mut [Rgb],
    pdf: &'a mut [f32],
}

impl BsdfSamplesMut<'_> {
    pub fn len(&self) -> usize {
        self.pdf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pdf.is_empty()
    }

    /// Sets entry `k` to `s` (None: no sample). A sample's density must be positive or NaN
    /// ([`Bsdf::sample`]), or it would read back as no sample.
    #[inline]
    pub fn set(&mut self, k: usize, s: Option<BsdfSample>) {
        debug_assert!(
            s.is_none_or(|s| !(s.pdf <= 0.0)),
            "a sample of density {s:?}"
        );
        let s = s.unwrap_or(BsdfSample {
            wi: Vec3::ZERO,
            weight: Rgb::ZERO,
            pdf: 0.0,
        });
        self.wi.set(k, s.wi);
        self.weight[k] = s.weight;
        self.pdf[k] = s.pdf;
    }

    /// Sets every entry to "no sample".
    pub fn clear(&mut self) {
        for c in self.wi.columns() {
            c.fill(0.0);
        }
        self.weight.fill(Rgb::ZERO);
        self.pdf.fill(0.0);
    }

    /// Entries `r`.
    pub fn slice(&mut self, r: Range<usize>) -> BsdfSamplesMut<'_> {
        BsdfSamplesMut {
            wi: self.wi.slice(r.clone()),
            weight: &mut self.weight[r.clone()],
            pdf: &mut self.pdf[r],
        }
    }
}

/// The plugin interface every BRDF implements. See the module docs for conventions.
pub trait Bsdf: Send + Sync + std::fmt::Debug {
    /// f_r(wo, wi) in 1/sr, without the cosine factor; zero below the surface.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb;
    /// Samples `wi` given `wo`, a 2D uniform sample `u` and a 1D sample `uc` that chooses
    /// between components. `None` when no direction can be produced (e.g. `wo` below the
    /// surface) or its density is not positive: a sample's `pdf` is positive (or NaN, from
    /// NaN inputs), never 0 or negative ([`BsdfSample::finish`] checks it).
    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample>;
    /// Solid-angle density with which `sample` produces `wi`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// [`Bsdf::sample`] of many queries at once, entry k of `out` for (`wo[k]`, `u[k]`,
    /// `uc[k]`), bit for bit the same: the renderer's wavefront integrator samples all hits
    /// on one material in one call. Models may override it with a batched (SIMD) form.
    /// The directions and sample points come as columns ([`Vec3Cols`], [`Vec2Cols`]) and
    /// the samples go to columns ([`BsdfSamplesMut`]): the queues' struct-of-arrays form.
    /// Every entry of `out` is written (no sample where the scalar call gives None).
    fn sample_many(&self, wo: Vec3Cols, u: Vec2Cols, uc: &[f32], mut out: BsdfSamplesMut) {
        let n = out.len();
        assert!(wo.len() == n && u.len() == n && uc.len() == n);
        for (k, &uc) in uc.iter().enumerate() {
            out.set(k, self.sample(wo.get(k), u.get(k), uc));
        }
    }
    /// [`Bsdf::eval`] and [`Bsdf::pdf`] of many direction pairs at once, `f[k]` and
    /// `pdf[k]` for (`wo[k]`, `wi[k]`), bit for bit the same: the renderer's wavefront
    /// integrator evaluates the light samples of all hits on one material in one call.
    /// Models may override it with a batched (SIMD) form.
    fn eval_pdf_many(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb], pdf: &mut [f32]) {
        for (((f, pdf), wo), wi) in f
            .iter_mut()
            .zip(pdf.iter_mut())
            .zip(wo.iter())
            .zip(wi.iter())
        {
            *f = self.eval(wo, wi);
            *pdf = self.pdf(wo, wi);
        }
    }
    /// [`Bsdf::eval`] of many direction pairs at once, `f[k]` for (`wo[k]`, `wi[k]`), bit
    /// for bit the values [`Bsdf::eval_pdf_many`] gives, for callers that need no density
    /// (the image estimators' representations that draw no samples of their own). The
    /// default calls [`Bsdf::eval_pdf_many`]; models whose density costs a share of the
    /// evaluation override it.
    fn eval_many(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb]) {
        let mut pdf = vec![0.0; f.len()];
        self.eval_pdf_many(wo, wi, f, &mut pdf);
    }
    fn flags(&self) -> Flags;
    /// Registry name of the model, for reports.
    fn name(&self) -> &str;
    /// Bytes this material holds (tables, samplers), for the speed/memory trade-off reports.
    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self)
    }
}

/// Runs `check(wo, wi, u, uc)` over a grid of direction pairs (viewer at 16 elevations to
/// 89.9 degrees and 4 azimuths, light over 16 x 16 directions of the hemisphere, with a
/// stratified 2D sample and a 1D sample each) and returns the first message it gives,
/// prefixed with the pair's angles.
pub fn probe_directions(
    mut check: impl FnMut(Vec3, Vec3, Vec2, f32) -> Option<String>,
) -> Option<String> {
    let dir = |t: f32, p: f32| {
        let (t, p) = (t.to_radians(), p.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    };
    for a in 0..16 {
        let theta_o = 89.9 * a as f32 / 15.0;
        for phi_o in [0.0f32, 45.0, 130.0, 270.0] {
            let wo = dir(theta_o, phi_o);
            for i in 0..16 {
                let theta_i = 89.9 * i as f32 / 15.0;
                for j in 0..16 {
                    let phi_i = 22.5 * j as f32;
                    let u = Vec2::new((i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0);
                    let uc = (a * 16 + j) as f32 / 256.0;
                    if let Some(m) = check(wo, dir(theta_i, phi_i), u, uc) {
                        return Some(format!(
                            "theta_o {theta_o:.1}, phi_o {phi_o}, theta_i {theta_i:.1}, phi_i {phi_i} degrees: {m}"
                        ));
                    }
                }
            }
        }
    }
    None
}

/// The first direction pair of [`probe_directions`] where `b`'s value, density or sample
/// weight is not finite, described with its angles; None when all are finite. Readers use
/// it to refuse a file whose values combine to overflow f32.
pub fn first_nonfinite(b: &dyn Bsdf) -> Option<String> {
    probe_directions(|wo, wi, u, uc| {
        let (f, pdf) = (b.eval(wo, wi), b.pdf(wo, wi));
        let s = b.sample(wo, u, uc);
        let ok = f.is_finite()
            && pdf.is_finite()
            && s.is_none_or(|s| s.weight.is_finite() && s.pdf.is_finite());
        (!ok).then(|| {
            format!(
                "value {:?}, density {pdf}, sample {:?}",
                f.to_array(),
                s.map(|s| (s.weight.to_array(), s.pdf))
            )
        })
    })
}
