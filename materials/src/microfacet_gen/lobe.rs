//! The Ashikhmin-Premože-Shirley microfacet generator (SIGGRAPH 2000) with a tabulated
//! distribution of normals as a lobe (rho = p(h) <h.n> F(k.h) / (4 g(k1) g(k2)), Ngan et
//! al. 2005 Eq. 3, sampled through the distribution of visible normals), and its registry
//! entry: the `sampled-microfacet` material (Ngan et al. 2005, section 5) with a built-in
//! or EXR distribution.

use super::synthetic::Shape;
use super::table::{DEFAULT_RES, Table};
use crate::columns::{Vec2Cols, Vec3Cols, Vec3ColsMut};
use crate::composite::Composite;
use crate::lobe::{self, Lobe};
use crate::math::V3;
use crate::registry::{
    Bounds, BuildContext, DefaultValue, ModelSchema, ParamKind, ParamRole, ParamSpec, Params,
    Registry,
};
use crate::simd::{self, LANES, MaskN, RgbxN, Vec3xN, f32xn, sel};
use crate::{Bsdf, Flags, ParamError, Rgb};
use glam::{DVec3, Vec2, Vec3};
use std::path::PathBuf;
use std::sync::Arc;

/// The generator as a lobe (per unit specular colour).
#[derive(Clone, Debug)]
pub struct SampledMicrofacet {
    pub table: Arc<Table>,
    pub f0: f64,
}

impl Lobe for SampledMicrofacet {
    fn model(&self) -> &'static str {
        "sampled-microfacet"
    }
    /// [`Table::rho`] in f32.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        Rgb::splat(self.table.rho(wo.into(), wi.into(), self.f0 as f32))
    }
    fn eval_f64(&self, wo: DVec3, wi: DVec3) -> [f64; 3] {
        [self.table.rho(wo.into(), wi.into(), self.f0); 3]
    }
    /// Lane 0 of [`SampledMicrofacet::sample_xn`]: one sampler for both.
    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<Vec3> {
        let u = [f32xn::splat(u.x), f32xn::splat(u.y)];
        let (wi, ok) = self.sample_xn(Vec3xN::splat(wo), u, f32xn::splat(uc));
        (simd::mask_bits(ok) & 1 != 0).then(|| wi.lane(0))
    }
    /// Half vectors visible from `wo` ([`Table::sample_visible`]), reflected.
    fn sample_xn(&self, wo: Vec3xN, u: [f32xn; 2], _uc: f32xn) -> (Vec3xN, MaskN) {
        let [s] = self.sample_groups([wo], [u]);
        s
    }
    /// Two lane vectors at a time, side by side ([`Table::sample_visible`]); a last
    /// lone lane vector alone.
    fn sample_batch(
        &self,
        wo: Vec3Cols,
        u: Vec2Cols,
        _uc: &[f32],
        mut wi: Vec3ColsMut,
        drawn: &mut [bool],
    ) {
        let n = drawn.len();
        assert!(wo.len() == n && u.len() == n && wi.len() == n);
        let mut put = |first: usize, s| lobe::store_drawn(s, first, &mut wi, drawn);
        for first in (0..n).step_by(2 * LANES) {
            let end = (first + 2 * LANES).min(n);
            let mid = (first + LANES).min(end);
            if mid == end {
                let [s] = self.sample_groups([wo.load(first)], [u.load(first)]);
                put(first, s);
            } else {
                let (wo2, u2) = ([wo.load(first), wo.load(mid)], [u.load(first), u.load(mid)]);
                let [s0, s1] = self.sample_groups(wo2, u2);
                put(first, s0);
                put(mid, s1);
            }
        }
    }
    /// Lane 0 of [`SampledMicrofacet::density`] (the visible-normal sampler's tables are
    /// read in lanes).
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = (Vec3xN::splat(wo), Vec3xN::splat(wi));
        let h = Self::half(wo, wi);
        self.density(wo, wi, h, self.table.p(h.x, h.y)).to_array()[0]
    }
    /// The generator's value ([`Table::rho_at`]) and density ([`SampledMicrofacet::density`])
    /// of `LANES` pairs, p(h) looked up once for both.
    fn eval_pdf_xn(&self, wo: Vec3xN, wi: Vec3xN) -> (RgbxN, f32xn) {
        let h = Self::half(wo, wi);
        let p_h = self.table.p(h.x, h.y);
        (self.value_at(wo, wi, h, p_h), self.density(wo, wi, h, p_h))
    }
    fn eval_xn(&self, wo: Vec3xN, wi: Vec3xN) -> RgbxN {
        let h = Self::half(wo, wi);
        self.value_at(wo, wi, h, self.table.p(h.x, h.y))
    }
    fn flags(&self) -> Flags {
        Flags::RECIPROCAL | Flags::GLOSSY
    }
    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self) + self.table.memory_bytes()
    }
}

impl SampledMicrofacet {
    /// The generator's value ([`Table::rho_at`]) of `LANES` pairs of half vector `h`, where
    /// the table's p(h) is `p_h`.
    #[inline(always)]
    fn value_at(&self, wo: Vec3xN, wi: Vec3xN, h: Vec3xN, p_h: f32xn) -> RgbxN {
        let v = self
            .table
            .rho_at(wo, wi, h, p_h, f32xn::splat(self.f0 as f32));
        RgbxN::new(v, v, v)
    }

    /// The unit half vector of `wo` and `wi`, zero where there is none.
    #[inline(always)]
    fn half(wo: Vec3xN, wi: Vec3xN) -> Vec3xN {
        let zero = f32xn::splat(0.0);
        (wo + wi).unit_or(V3::new(zero, zero, zero))
    }

    /// The density of wi: that of the visible normal `h` (its p(h) `p_h`) converted to the
    /// density of wi, zero below the surface or where not finite.
    #[inline(always)]
    fn density(&self, wo: Vec3xN, wi: Vec3xN, h: Vec3xN, p_h: f32xn) -> f32xn {
        let p = lobe::half_to_incident_pdf(self.table.pdf_visible_at(wo, h, p_h), wo.dot(h));
        let ok = lobe::both_above(wo, wi) & p.is_finite();
        sel(ok, p, f32xn::splat(0.0))
    }

    /// [`Lobe::sample_xn`] of `N` lane vectors side by side.
    #[inline(always)]
    fn sample_groups<const N: usize>(
        &self,
        wo: [Vec3xN; N],
        xy: [[f32xn; 2]; N],
    ) -> [(Vec3xN, MaskN); N] {
        let h = self
            .table
            .sample_visible(wo, xy.map(|[x, _]| x), xy.map(|[_, y]| y));
        std::array::from_fn(|g| {
            let (h, drawn) = h[g];
            let (wi, ok) = lobe::reflect_above(wo[g], h);
            (wi, drawn & ok)
        })
    }
}

const SCHEMA_PARAMS: &[ParamSpec] = &[
    crate::analytic::common::DIFFUSE,
    crate::analytic::common::SPECULAR,
    ParamSpec {
        name: "distribution",
        kind: ParamKind::Text,
        role: ParamRole::Setting,
        bounds: Bounds::closed(0.0, 0.0),
        default: DefaultValue::Choice("beckmann"),
        doc: "an EXR table written by `lobe microfacet` (relative to the scene), or beckmann, brushed, satin, velvet",
        fit: None,
    },
    ParamSpec {
        name: "alpha_x",
        kind: ParamKind::Scalar,
        role: ParamRole::Lobe,
        bounds: Bounds::closed(0.01, 2.0),
        default: DefaultValue::Scalar(0.2),
        doc: "Beckmann width along x (distribution beckmann only)",
        fit: None,
    },
    ParamSpec {
        name: "alpha_y",
        kind: ParamKind::Scalar,
        role: ParamRole::Lobe,
        bounds: Bounds::closed(0.01, 2.0),
        default: DefaultValue::Scalar(0.2),
        doc: "Beckmann width along y (distribution beckmann only)",
        fit: None,
    },
    ParamSpec {
        name: "f0",
        kind: ParamKind::Scalar,
        role: ParamRole::Lobe,
        bounds: Bounds::closed(0.0, 1.0),
        default: DefaultValue::Scalar(1.0),
        doc: "Schlick's reflectance at normal incidence (1: no Fresnel term)",
        fit: None,
    },
    ParamSpec {
        name: "resolution",
        kind: ParamKind::Integer,
        role: ParamRole::Setting,
        bounds: Bounds::closed(9.0, 2049.0),
        default: DefaultValue::Scalar(DEFAULT_RES as f64),
        doc: "nodes per side when a closed-form distribution is tabulated",
        fit: None,
    },
];

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "sampled-microfacet",
    summary: "Ashikhmin-Premoze-Shirley 2000 generator: p(h) F(k.h) / (4 g(k1) g(k2)) with a tabulated p",
    params: SCHEMA_PARAMS,
};

fn build(p: &Params, ctx: &BuildContext) -> Result<Arc<dyn Bsdf>, ParamError> {
    let dist = p.text("distribution");
    let n = p.scalar("resolution").round() as usize;
    let err = |m: String| ParamError::new(format!("{}.distribution", p.path), m);
    let table = match dist {
        "beckmann" => {
            let shape = Shape::Beckmann {
                alpha_x: p.scalar("alpha_x"),
                alpha_y: p.scalar("alpha_y"),
            };
            Table::from_fn(n, |h| shape.density(h)).map_err(err)?
        }
        name => match Shape::synthetic(name) {
            Some(shape) => Table::from_fn(n, |h| shape.density(h)).map_err(err)?,
            None => {
                Table::read_exr(&distribution_file(p, ctx).expect("not built in")).map_err(err)?
            }
        },
    };
    let lobe: Arc<dyn Lobe> = Arc::new(SampledMicrofacet {
        table: Arc::new(table),
        f0: p.scalar("f0"),
    });
    Ok(Arc::new(Composite::new(
        "sampled-microfacet",
        p.color("diffuse"),
        vec![(p.color("specular"), lobe)],
    )))
}

/// The EXR table a description reads, unless its distribution is a built-in one.
fn distribution_file(p: &Params, ctx: &BuildContext) -> Option<PathBuf> {
    let dist = p.text("distribution");
    (dist != "beckmann" && Shape::synthetic(dist).is_none())
        .then(|| crate::measured::material::resolve(ctx, dist))
}

pub fn register(r: &mut Registry) {
    r.register(SCHEMA, build);
    r.register_inputs(SCHEMA.name, |p, ctx| {
        distribution_file(p, ctx).into_iter().collect()
    });
}
