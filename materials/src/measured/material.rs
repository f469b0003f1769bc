//! The `merl` (and, with the other tables, `binned` and `rgl`) materials: a measured table
//! evaluated by lookup and importance sampled with a [`TabulatedSampler`]. Tables and their
//! samplers are cached in the [`BuildContext`] by file, so a scene loads each once and
//! shares it between shapes; nothing is read unless a shape uses the material.

use super::binned::Binned;
use super::format::{self, Format};
use super::merl::Merl;
use super::rgl::Rgl;
use super::sampler::TabulatedSampler;
use crate::ParamError;
use crate::bsdf::{Bsdf, BsdfSample, BsdfSamplesMut, Flags, Rgb};
use crate::columns::{Vec2Cols, Vec3Cols};
use crate::math::{Single, V3, maximum};
use crate::registry::{
    Bounds, BuildContext, DefaultValue, ModelSchema, ParamKind, ParamRole, ParamSpec, Params,
    Registry,
};
use crate::simd::{self, RgbxN, Vec3xN};
use glam::{Vec2, Vec3};
use std::any::Any;
use std::path::PathBuf;
use std::sync::Arc;

/// A loaded table, looked up by one generic function for one pair and for lanes of
/// pairs ([`MeasuredTable::value`]); a new tabulated format is one more variant.
#[derive(Debug)]
pub enum MeasuredTable {
    /// A MERL table, trilinear ([`Merl::interpolate`]) or by nearest bin
    /// ([`Merl::nearest`]).
    Merl { table: Merl, interpolate: bool },
    /// The study's binned 4D data, empty bins filled ([`Binned::bin_value`]).
    Binned(Binned),
}

impl MeasuredTable {
    /// f_r(wo, wi) in 1/sr per channel (one pair or lanes), zero below the surface;
    /// negative bins of binned data (noise of a measurement, e.g. tabulated from an
    /// unclamped RGL file) render as zero.
    #[inline]
    pub fn value<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> [T; 3] {
        match self {
            Self::Merl {
                table,
                interpolate: true,
            } => table.interpolate(wi, wo),
            Self::Merl {
                table,
                interpolate: false,
            } => table.nearest(wi, wo),
            Self::Binned(table) => table.bin_value(wi, wo).map(|x| maximum(x, T::of32(0.0))),
        }
    }

    /// [`MeasuredTable::value`] of one pair.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        Rgb::from(self.value::<f32>(wo.into(), wi.into()))
    }

    /// [`MeasuredTable::value`] of `LANES` pairs.
    fn eval_lanes(&self, wo: Vec3xN, wi: Vec3xN) -> RgbxN {
        let [r, g, b] = self.value(wo, wi);
        RgbxN::new(r, g, b)
    }

    pub fn is_isotropic(&self) -> bool {
        match self {
            Self::Merl { .. } => true,
            Self::Binned(table) => !table.anisotropic,
        }
    }

    pub fn memory_bytes(&self) -> usize {
        match self {
            Self::Merl { table, .. } => table.memory_bytes(),
            Self::Binned(table) => table.values.len() * std::mem::size_of::<Option<[f32; 3]>>(),
        }
    }
}

/// A measured material: a table and its sampler.
#[derive(Debug, Clone)]
pub struct Measured {
    name: &'static str,
    table: Arc<MeasuredTable>,
    sampler: Arc<TabulatedSampler>,
}

impl Measured {
    pub fn new(name: &'static str, table: Arc<MeasuredTable>) -> Self {
        TABLES_BUILT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let t = table.clone();
        let sampler = Arc::new(TabulatedSampler::new(move |wo, wi| {
            t.eval(wo, wi).luminance()
        }));
        Self {
            name,
            table,
            sampler,
        }
    }

    /// The samples of the directions `wi[i]` with densities `pdf[i]` drawn for queries
    /// `first + i` (`i` in `drawn`, one to `LANES` of them) to `out`: their values a lane
    /// vector at a time ([`MeasuredTable::value`]), their weights `f cos / pdf`, and "no
    /// sample" where a weight is not finite ([`BsdfSample::weight_where`], per lane).
    fn weigh_samples(
        &self,
        wo: Vec3Cols,
        first: usize,
        drawn: &[usize],
        (wi, pdf): (&[Vec3; simd::LANES], &[f32; simd::LANES]),
        out: &mut BsdfSamplesMut,
    ) {
        let queries: [usize; simd::LANES] = simd::lanes(|l| first + drawn[l.min(drawn.len() - 1)]);
        let f = self.table.eval_lanes(
            wo.lanes_of(&queries[..drawn.len()]),
            Vec3xN::from_array(&simd::lanes_of(drawn, |i| wi[i])),
        );
        for (lane, &i) in drawn.iter().enumerate() {
            let v = f.lane(lane).to_array();
            let (weight, keep) = BsdfSample::weight_where(wi[i].z, pdf[i], v);
            let s = BsdfSample {
                wi: wi[i],
                weight: Rgb::from(weight),
                pdf: pdf[i],
            };
            out.set(first + i, keep.then_some(s));
        }
    }
}

impl Bsdf for Measured {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.table.eval(wo, wi)
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        let wi = self.sampler.sample(wo, u, uc)?;
        BsdfSample::finish(wi, || self.sampler.pdf(wo, wi), || self.eval(wo, wi))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.sampler.pdf(wo, wi)
    }

    /// Directions and densities from the sampler one query at a time, then the values of
    /// the sampled directions a lane vector at a time ([`MeasuredTable::value`]); bit for bit
    /// [`Measured::sample`] (a sample's value is only needed once its density is positive).
    fn sample_many(&self, wo: Vec3Cols, u: Vec2Cols, uc: &[f32], mut out: BsdfSamplesMut) {
        let n = out.len();
        assert!(wo.len() == n && u.len() == n && uc.len() == n);
        // `LANES` queries at a time: directions one by one, their densities in lanes
        // (TabulatedSampler::density), the values of those with a density in lanes.
        for start in (0..n).step_by(simd::LANES) {
            let len = (n - start).min(simd::LANES);
            let at = |i: usize| start + i.min(len - 1);
            let [ux, uy] = u.load(start).map(|c| c.to_array());
            let wi = simd::lanes(|i| {
                let u = Vec2::new(ux[i], uy[i]);
                (i < len)
                    .then(|| self.sampler.sample(wo.get(at(i)), u, uc[at(i)]))
                    .flatten()
            });
            let dirs = simd::lanes(|i| wi[i].unwrap_or(Vec3::Z));
            let pdf = self
                .sampler
                .density(wo.load(start), Vec3xN::from_array(&dirs))
                .to_array();
            let mut drawn = [0usize; simd::LANES];
            let mut kept = 0;
            for i in 0..len {
                out.set(start + i, None);
                if wi[i].is_some() && pdf[i] > 0.0 {
                    drawn[kept] = i;
                    kept += 1;
                }
            }
            if kept > 0 {
                self.weigh_samples(wo, start, &drawn[..kept], (&dirs, &pdf), &mut out);
            }
        }
    }

    /// The values of the pairs above the surface and the sampler's densities, `LANES` at a
    /// time ([`MeasuredTable::value`], [`TabulatedSampler::density`]).
    fn eval_pdf_many(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb], pdf: &mut [f32]) {
        let n = f.len();
        assert!(wo.len() == n && wi.len() == n && pdf.len() == n);
        f.fill(Rgb::ZERO);
        let above = |k: usize| !(wo.z()[k] <= 0.0 || wi.z()[k] <= 0.0);
        simd::chunks_where(n, above, |idx| {
            let v = self.table.eval_lanes(wo.lanes_of(idx), wi.lanes_of(idx));
            for (lane, &k) in idx.iter().enumerate() {
                f[k] = v.lane(lane);
            }
        });
        for (start, chunk) in pdf.chunks_mut(simd::LANES).enumerate() {
            let first = simd::LANES * start;
            let p = self.sampler.density(wo.load(first), wi.load(first));
            chunk.copy_from_slice(&p.to_array()[..chunk.len()]);
        }
    }

    fn flags(&self) -> Flags {
        // Measured data need not be reciprocal nor bounded.
        let iso = if self.table.is_isotropic() {
            Flags::ISOTROPIC
        } else {
            Flags::NONE
        };
        iso | Flags::DIFFUSE | Flags::GLOSSY
    }

    fn name(&self) -> &str {
        self.name
    }
    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self) + self.table.memory_bytes() + self.sampler.memory_bytes()
    }
}

/// Resolves `file` against the scene folder.
pub fn resolve(ctx: &BuildContext, file: &str) -> PathBuf {
    let p = PathBuf::from(file);
    if p.is_absolute() {
        p
    } else {
        ctx.base_dir.join(p)
    }
}

/// The table file of a `merl`, `binned` or `rgl` description, checked to hold `format`
/// (by content: a binned file named `.binary` is refused by `merl`, naming `binned`).
fn table_path(p: &Params, ctx: &BuildContext, format: Format) -> Result<PathBuf, ParamError> {
    let path = resolve(ctx, p.text("file"));
    format::expect(&path, format)
        .map_err(|e| ParamError::new(format!("{}.file", p.path), e.to_string()))?;
    Ok(path)
}

/// The file a `merl`, `binned` or `rgl` description reads.
fn table_inputs(p: &Params, ctx: &BuildContext) -> Vec<PathBuf> {
    vec![resolve(ctx, p.text("file"))]
}

/// Measured tables built (with their samplers) since the process started: lets tests show
/// that a scene builds only the tables its shapes use.
pub static TABLES_BUILT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// The cached material for (kind, file, options), built with `make` on first use.
pub fn cached(
    ctx: &BuildContext,
    key: String,
    make: impl FnOnce() -> Result<Measured, ParamError>,
) -> Result<Arc<dyn Bsdf>, ParamError> {
    let mut cache = ctx.tables.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(v) = cache.get(&key)
        && let Some(m) = v.downcast_ref::<Measured>()
    {
        return Ok(Arc::new(m.clone()));
    }
    let m = make()?;
    cache.insert(key, Arc::new(m.clone()) as Arc<dyn Any + Send + Sync>);
    Ok(Arc::new(m))
}

const FILE: ParamSpec = ParamSpec {
    name: "file",
    kind: ParamKind::Text,
    role: ParamRole::Setting,
    bounds: Bounds::closed(0.0, 0.0),
    default: DefaultValue::Required,
    doc: "path of the table (relative to the scene file)",
    fit: None,
};

pub const MERL_SCHEMA: ModelSchema = ModelSchema {
    name: "merl",
    summary: "a MERL isotropic BRDF table (.binary), looked up trilinearly or by nearest bin",
    params: &[
        FILE,
        ParamSpec {
            name: "interpolate",
            kind: ParamKind::Bool,
            role: ParamRole::Setting,
            bounds: Bounds::closed(0.0, 0.0),
            default: DefaultValue::Bool(true),
            doc: "trilinear interpolation between bin centres (false: nearest bin)",
            fit: None,
        },
    ],
};

fn build_merl(p: &Params, ctx: &BuildContext) -> Result<Arc<dyn Bsdf>, ParamError> {
    let path = table_path(p, ctx, Format::Merl)?;
    let interpolate = p.flag("interpolate");
    let key = format!("merl:{}:{interpolate}", path.display());
    cached(ctx, key, || {
        let table = Merl::read(&path)
            .map_err(|e| ParamError::new(format!("{}.file", p.path), e.to_string()))?;
        Ok(Measured::new(
            "merl",
            Arc::new(MeasuredTable::Merl { table, interpolate }),
        ))
    })
}

pub const BINNED_SCHEMA: ModelSchema = ModelSchema {
    name: "binned",
    summary: "the study's binned 4D data (docs/binned-format.md), nearest bin, empty bins filled from their neighbours",
    params: &[FILE],
};

fn build_binned(p: &Params, ctx: &BuildContext) -> Result<Arc<dyn Bsdf>, ParamError> {
    let path = table_path(p, ctx, Format::Binned)?;
    let key = format!("binned:{}", path.display());
    cached(ctx, key, || {
        let table = Binned::read(&path)
            .map_err(|e| ParamError::new(format!("{}.file", p.path), e.to_string()))?;
        if table.filled() == 0 {
            return Err(ParamError::new(
                format!("{}.file", p.path),
                format!("{}: every bin is empty; expected some data", path.display()),
            ));
        }
        Ok(Measured::new(
            "binned",
            Arc::new(MeasuredTable::Binned(table.filled_copy())),
        ))
    })
}

/// An RGL material: Mitsuba's `measured` evaluation and sampling (the table's own
/// luminance and visible-normal warps, nothing mixed in). The luminance warp is made from
/// the same measurement as the colour table, so it reaches every direction the material
/// reflects into. A 10 % cosine-sampling mixture, as a guard against directions it might
/// miss, costs 13 % more squared error per sample than Mitsuba's render on the
/// golden-yellow bunny (docs/performance.md) and buys nothing measurable.
#[derive(Debug, Clone)]
pub struct RglBsdf {
    table: Arc<Rgl>,
    /// Clamp the tables' small negative values at zero.
    clamp: bool,
}

impl RglBsdf {
    pub fn new(table: Arc<Rgl>, clamp: bool) -> Self {
        Self { table, clamp }
    }

    fn clamped(&self, v: Rgb) -> Rgb {
        if self.clamp {
            v.map(|x| crate::math::maximum(x, 0.0))
        } else {
            v
        }
    }

    /// The sample of direction `wi` from its projected value and density.
    #[inline]
    fn finish(&self, wi: Vec3, projected: Rgb, pdf: f32) -> Option<BsdfSample> {
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            weight: self.clamped(projected) / pdf,
            pdf,
        })
    }

    /// `eval` from the projected value.
    #[inline]
    fn f(&self, wi: Vec3, projected: Rgb) -> Rgb {
        let v = self.clamped(projected) / wi.z;
        if v.is_finite() { v } else { Rgb::ZERO }
    }
}

impl Bsdf for RglBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.f(wi, self.table.eval_projected(wo, wi))
    }

    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        // The table's own warp: its density and value come with the sample.
        let (wi, p, v, ok) = self.table.sample_value::<f32>(wo.into(), [u.x, u.y]);
        if !ok {
            return None;
        }
        self.finish(wi.into(), Rgb::from(v), p)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.table.pdf(wo, wi)
    }

    /// The pairs above the surface a lane vector at a time through [`Rgl::eval_projected_pdf`].
    fn eval_pdf_many(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb], pdf: &mut [f32]) {
        let n = f.len();
        assert!(wo.len() == n && wi.len() == n && pdf.len() == n);
        f.fill(Rgb::ZERO);
        pdf.fill(0.0);
        let above = |k: usize| !(wo.z()[k] <= 0.0 || wi.z()[k] <= 0.0);
        simd::chunks_where(n, above, |idx| {
            let ([r, g, b], p) = self
                .table
                .eval_projected_pdf(wo.lanes_of(idx), wi.lanes_of(idx));
            let (v, p) = (RgbxN::new(r, g, b), p.to_array());
            for (lane, &k) in idx.iter().enumerate() {
                f[k] = self.f(wi.get(k), v.lane(lane));
                pdf[k] = p[lane];
            }
        });
    }

    /// The queries above the surface a lane vector at a time ([`Rgl::sample_value`]).
    fn sample_many(&self, wo: Vec3Cols, u: Vec2Cols, uc: &[f32], mut out: BsdfSamplesMut) {
        let n = out.len();
        assert!(wo.len() == n && u.len() == n && uc.len() == n);
        out.clear();
        simd::chunks_where(
            n,
            |k| !(wo.z()[k] <= 0.0),
            |idx| {
                let (wi, p, [r, g, b], ok) =
                    self.table.sample_value(wo.lanes_of(idx), u.lanes_of(idx));
                let (v, p, ok) = (RgbxN::new(r, g, b), p.to_array(), simd::mask_bits(ok));
                for (lane, &k) in idx.iter().enumerate() {
                    if ok >> lane & 1 == 1 {
                        out.set(k, self.finish(wi.lane(lane), v.lane(lane), p[lane]));
                    }
                }
            },
        );
    }

    fn flags(&self) -> Flags {
        let iso = if self.table.is_isotropic() {
            Flags::ISOTROPIC
        } else {
            Flags::NONE
        };
        iso | Flags::DIFFUSE | Flags::GLOSSY
    }

    fn name(&self) -> &str {
        "rgl"
    }
    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self) + self.table.memory_bytes()
    }
}

pub const RGL_SCHEMA: ModelSchema = ModelSchema {
    name: "rgl",
    summary: "an RGL measured BSDF (*_rgb.bsdf, Dupuy and Jakob 2018), evaluated and sampled as Mitsuba 3's measured plugin",
    params: &[
        FILE,
        ParamSpec {
            name: "clamp",
            kind: ParamKind::Bool,
            role: ParamRole::Setting,
            bounds: Bounds::closed(0.0, 0.0),
            default: DefaultValue::Bool(true),
            doc: "clamp the tables' small negative values at zero (false: exactly Mitsuba's measured plugin)",
            fit: None,
        },
    ],
};

fn build_rgl(p: &Params, ctx: &BuildContext) -> Result<Arc<dyn Bsdf>, ParamError> {
    let path = table_path(p, ctx, Format::Rgl)?;
    let key = format!("rgl:{}", path.display());
    let mut cache = ctx.tables.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(v) = cache.get(&key)
        && let Some(t) = v.downcast_ref::<Arc<Rgl>>()
    {
        return Ok(Arc::new(RglBsdf::new(t.clone(), p.flag("clamp"))));
    }
    let t = Arc::new({
        TABLES_BUILT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Rgl::read(&path).map_err(|e| ParamError::new(format!("{}.file", p.path), e.to_string()))?
    });
    cache.insert(key, Arc::new(t.clone()) as Arc<dyn Any + Send + Sync>);
    Ok(Arc::new(RglBsdf::new(t, p.flag("clamp"))))
}

pub fn register(r: &mut Registry) {
    r.register(MERL_SCHEMA, build_merl);
    r.register(BINNED_SCHEMA, build_binned);
    r.register(RGL_SCHEMA, build_rgl);
    for name in [MERL_SCHEMA.name, BINNED_SCHEMA.name, RGL_SCHEMA.name] {
        r.register_inputs(name, table_inputs);
    }
}
