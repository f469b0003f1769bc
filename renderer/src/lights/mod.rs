//! Light sources: lat-long environment maps, constant environments, point and directional
//! lights, and diffuse area lights on spheres, rectangles and meshes (Mitsuba 3's `envmap`,
//! `constant`, `point`, `directional` and `area` emitters, same parameters and meanings).
//!
//! Area lights are one-sided: they emit on the side their (possibly flipped) normal faces.
//! Sampling: spheres seen from outside are sampled uniformly in the cone they subtend
//! (pbrt-v4 `Sphere::Sample`), from inside uniformly by area; rectangles and meshes
//! uniformly by area (a mesh picks a triangle in proportion to its area).

pub mod envmap;

use crate::Rgb;
use crate::geometry::{Interaction, Rectangle, Sphere, Triangle};
pub use envmap::EnvMap;
use glam::{Vec2, Vec3};
use lobe_materials::frame::Frame;
use lobe_materials::math::{Arith, V3, abs, gt, le, select, sqrt};
use lobe_materials::sampling::cdf::Discrete1D;
use lobe_materials::sampling::warp::{
    UNIFORM_SPHERE_PDF, square_to_uniform_cone, square_to_uniform_sphere,
    square_to_uniform_triangle, uniform_cone_pdf,
};
use lobe_materials::simd::{self, Vec3xN};
use lobe_materials::simd::{LANES, f32xn};
use lobe_materials::{Vec2Cols, Vec3Cols, Vec3s};

/// Emitting geometry of an area light.
#[derive(Clone, Debug)]
pub enum AreaShape {
    Sphere {
        sphere: Sphere,
        flip: bool,
    },
    Rectangle {
        rect: Rectangle,
        flip: bool,
    },
    /// Triangles with their emitting-side unit normals, chosen by area.
    Mesh {
        tris: Vec<(Triangle, Vec3)>,
        cdf: Discrete1D,
        area: f32,
    },
}

#[derive(Clone, Debug)]
pub enum Light {
    Env(Box<EnvMap>),
    Constant {
        radiance: Rgb,
    },
    Point {
        position: Vec3,
        intensity: Rgb,
    },
    /// `direction` is the direction of propagation (unit).
    Directional {
        direction: Vec3,
        irradiance: Rgb,
    },
    Area {
        shape: AreaShape,
        radiance: Rgb,
    },
}

/// A light sample seen from a reference point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the reference point toward the light.
    pub wi: Vec3,
    /// Incident radiance (or irradiance-like value for delta lights) before the cosine.
    pub li: Rgb,
    /// Solid-angle density (1 for delta lights).
    pub pdf: f32,
    pub delta: bool,
    /// Point on the light and its normal, for the shadow ray (None: at infinity).
    pub p: Option<(Vec3, Vec3)>,
}

/// Light samples of a batch of points, struct of arrays (index k for point k): direction
/// toward the light, radiance, solid-angle density (0: no sample), delta flag, and the
/// point on the light with its normal ([`LightSample::p`]).
#[derive(Clone, Debug, Default)]
pub struct LightSamples {
    pub wi: Vec3s,
    pub li: Vec<Rgb>,
    pub pdf: Vec<f32>,
    pub delta: Vec<bool>,
    pub at: Vec<Option<(Vec3, Vec3)>>,
}

impl LightSamples {
    /// `n` entries, all "no sample".
    pub fn reset(&mut self, n: usize) {
        self.wi.clear();
        self.wi.resize(n);
        self.li.clear();
        self.li.resize(n, Rgb::ZERO);
        self.pdf.clear();
        self.pdf.resize(n, 0.0);
        self.delta.clear();
        self.delta.resize(n, false);
        self.at.clear();
        self.at.resize(n, None);
    }

    /// Sets entry `k` to a sample.
    #[inline]
    pub fn set(&mut self, k: usize, ls: &LightSample) {
        self.wi.set(k, ls.wi);
        self.li[k] = ls.li;
        self.pdf[k] = ls.pdf;
        self.delta[k] = ls.delta;
        self.at[k] = ls.p;
    }

    /// Copies entry `from` of `src` to entry `k`.
    #[inline]
    pub fn copy_from(&mut self, k: usize, src: &LightSamples, from: usize) {
        self.wi.set(k, src.wi.get(from));
        self.li[k] = src.li[from];
        self.pdf[k] = src.pdf[from];
        self.delta[k] = src.delta[from];
        self.at[k] = src.at[from];
    }
}

impl Light {
    /// [`Light::sample_li`] of the points `p[k]` with samples `u[k]` into `out` (reset to
    /// `u.len()` entries), the same values: environment maps, which do not depend on the
    /// point, sample the whole batch in SIMD lanes ([`EnvMap::sample_many`]), as do
    /// rectangles (points loaded from their columns); other lights one point at a time.
    ///
    /// # Panics
    /// When `p` and `u` differ in length.
    pub fn sample_li_many(&self, p: Vec3Cols, u: Vec2Cols, out: &mut LightSamples) {
        assert_eq!(p.len(), u.len(), "a point per light sample");
        out.reset(u.len());
        match self {
            Light::Env(env) => {
                env.sample_many(u, out.wi.cols_mut(), &mut out.li, &mut out.pdf);
                return;
            }
            Light::Area {
                shape: AreaShape::Rectangle { rect, flip },
                radiance,
            } => {
                sample_rectangle_many(rect, *flip, *radiance, p, u, out);
                return;
            }
            _ => {}
        }
        for (k, (p, u)) in p.iter().zip(u.iter()).enumerate() {
            if let Some(ls) = self.sample_li(p, u) {
                out.set(k, &ls);
            }
        }
    }

    /// [`Light::le_pdf_infinite`] of many directions, the same values (environment maps
    /// in SIMD lanes: [`EnvMap::eval_pdf_many`]).
    pub fn le_pdf_infinite_many(&self, dirs: Vec3Cols, out: &mut [(Rgb, f32)]) {
        match self {
            Light::Env(env) => env.eval_pdf_many(dirs, out),
            _ => {
                for (o, d) in out.iter_mut().zip(dirs.iter()) {
                    *o = self.le_pdf_infinite(d);
                }
            }
        }
    }

    pub fn is_infinite(&self) -> bool {
        matches!(
            self,
            Light::Env(_) | Light::Constant { .. } | Light::Directional { .. }
        )
    }

    /// Samples incident light at point `p`.
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Env(env) => {
                let (wi, li, pdf) = env.sample(u)?;
                Some(LightSample {
                    wi,
                    li,
                    pdf,
                    delta: false,
                    p: None,
                })
            }
            Light::Constant { radiance } => Some(LightSample {
                wi: square_to_uniform_sphere(u),
                li: *radiance,
                pdf: UNIFORM_SPHERE_PDF,
                delta: false,
                p: None,
            }),
            Light::Point {
                position,
                intensity,
            } => {
                let d = *position - p;
                let d2 = d.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                Some(LightSample {
                    wi: d / d2.sqrt(),
                    li: *intensity / d2,
                    pdf: 1.0,
                    delta: true,
                    p: Some((*position, Vec3::ZERO)),
                })
            }
            Light::Directional {
                direction,
                irradiance,
            } => Some(LightSample {
                wi: -*direction,
                li: *irradiance,
                pdf: 1.0,
                delta: true,
                p: None,
            }),
            Light::Area { shape, radiance } => {
                let (q, n, pdf) = shape.sample(p, u)?;
                let (wi, dist2, lit) = toward_emitter(V3::from(p), V3::from(q), V3::from(n));
                if !(dist2 > 0.0) || !(pdf > 0.0) {
                    return None;
                }
                let wi = wi.into();
                let li = if lit { *radiance } else { Rgb::ZERO };
                Some(LightSample {
                    wi,
                    li,
                    pdf,
                    delta: false,
                    p: Some((q, n)),
                })
            }
        }
    }

    /// Radiance of an infinite light arriving along world direction `d` (pointing away
    /// from the scene).
    #[inline]
    pub fn le_infinite(&self, d: Vec3) -> Rgb {
        match self {
            Light::Env(env) => env.eval(d),
            Light::Constant { radiance } => *radiance,
            _ => Rgb::ZERO,
        }
    }

    /// Radiance of an infinite light along `d` and the density with which `sample_li`
    /// picks `d`, in one evaluation.
    #[inline]
    pub fn le_pdf_infinite(&self, d: Vec3) -> (Rgb, f32) {
        match self {
            Light::Env(env) => env.eval_pdf(d),
            Light::Constant { radiance } => (*radiance, UNIFORM_SPHERE_PDF),
            _ => (Rgb::ZERO, 0.0),
        }
    }

    /// Radiance leaving an area light at `it` toward direction `w` (unit, away from it).
    #[inline]
    pub fn le_area(&self, it: &Interaction, w: Vec3) -> Rgb {
        match self {
            Light::Area { radiance, .. } if it.ng.dot(w) > 0.0 => *radiance,
            _ => Rgb::ZERO,
        }
    }

    /// Solid-angle density with which `sample_li` from `p` picks the area-light point `it`.
    pub fn pdf_area(&self, p: Vec3, it: &Interaction) -> f32 {
        match self {
            Light::Area { shape, .. } => shape.pdf(p, it.p, it.ng),
            _ => 0.0,
        }
    }
}

/// [`Light::sample_li`] of a rectangle emitter for many points, a lane vector at a time: the
/// lane instantiations of [`Rectangle::point_of`], [`area_to_solid_angle`] and
/// [`toward_emitter`], bit for bit the same.
fn sample_rectangle_many(
    rect: &Rectangle,
    flip: bool,
    radiance: Rgb,
    p: Vec3Cols,
    u: Vec2Cols,
    out: &mut LightSamples,
) {
    let zero = f32xn::splat(0.0);
    let n = Vec3xN::splat(if flip { -rect.n } else { rect.n });
    let area_pdf = f32xn::splat(1.0 / rect.area());
    for first in (0..u.len()).step_by(LANES) {
        let len = (u.len() - first).min(LANES);
        let [ux, uy] = u.load(first);
        let pp = p.load(first);
        let q = rect.point_of(ux, uy);
        let pdf = area_to_solid_angle(pp, q, n, area_pdf);
        let (wi, dist2, lit) = toward_emitter(pp, q, n);
        let ok = dist2.simd_gt(zero) & pdf.simd_gt(zero);
        let (ok, lit, pdf) = (simd::mask_bits(ok), simd::mask_bits(lit), pdf.to_array());
        let (wi, q) = (wi.to_array(), q.to_array());
        for i in 0..len {
            if ok & (1 << i) != 0 {
                let k = first + i;
                out.wi.set(k, wi[i]);
                out.li[k] = if lit & (1 << i) != 0 {
                    radiance
                } else {
                    Rgb::ZERO
                };
                out.pdf[k] = pdf[i];
                out.at[k] = Some((q[i], n.lane(0)));
            }
        }
    }
}

/// The solid-angle density at `p` of a point `q` (normal `n`) drawn with area density
/// `area_pdf`: `area_pdf dist^2 / |cos|`, zero where the cosine or the distance vanishes;
/// for one point and lanes of them.
#[inline(always)]
fn area_to_solid_angle<T: Arith>(p: V3<T>, q: V3<T>, n: V3<T>, area_pdf: T) -> T {
    let zero = T::of(0.0);
    let d = q - p;
    let dist2 = d.length_squared();
    let cos = abs(n.dot(d) / sqrt(dist2));
    select(
        le(cos, zero) | !gt(dist2, zero),
        zero,
        area_pdf * dist2 / cos,
    )
}

/// The unit direction from `p` to an emitter's point `q` (a division per component, as
/// glam's `Vec3 / f32`), the squared distance, and whether the emitter's one-sided normal
/// `n` faces `p` (emission toward -wi); for one point and lanes of them.
#[inline(always)]
fn toward_emitter<T: Arith>(p: V3<T>, q: V3<T>, n: V3<T>) -> (V3<T>, T, T::Mask) {
    let d = q - p;
    let dist2 = d.length_squared();
    let wi = d / sqrt(dist2);
    (wi, dist2, gt(n.dot(-wi), T::of(0.0)))
}

/// [`area_to_solid_angle`] of one point.
fn area_to_solid_angle_at(p: Vec3, q: Vec3, n: Vec3, area_pdf: f32) -> f32 {
    area_to_solid_angle(V3::from(p), V3::from(q), V3::from(n), area_pdf)
}

impl AreaShape {
    /// Builds a mesh emitter from triangles and their emitting normals.
    pub fn mesh(tris: Vec<(Triangle, Vec3)>) -> Option<Self> {
        let areas: Vec<f32> = tris.iter().map(|(t, _)| t.area()).collect();
        let area: f32 = areas.iter().sum();
        if !(area > 0.0) {
            return None;
        }
        Some(AreaShape::Mesh {
            cdf: Discrete1D::new(&areas),
            tris,
            area,
        })
    }

    pub fn area(&self) -> f32 {
        match self {
            AreaShape::Sphere { sphere, .. } => sphere.area(),
            AreaShape::Rectangle { rect, .. } => rect.area(),
            AreaShape::Mesh { area, .. } => *area,
        }
    }

    fn sphere_cone(sphere: &Sphere, p: Vec3) -> Option<(f32, f32)> {
        let d2 = (sphere.center - p).length_squared();
        let r2 = sphere.radius * sphere.radius;
        if d2 <= r2 * 1.0001 {
            return None;
        }
        let sin2 = r2 / d2;
        let cos_max = (1.0 - sin2).max(0.0).sqrt();
        Some((cos_max, d2.sqrt()))
    }

    /// Samples a point: (point, emitting-side unit normal, solid-angle pdf from `p`).
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        match self {
            AreaShape::Sphere { sphere, flip } => {
                let sign = if *flip { -1.0 } else { 1.0 };
                match Self::sphere_cone(sphere, p) {
                    Some((cos_max, dc)) if cos_max < 0.99999 => {
                        let axis = (sphere.center - p) / dc;
                        let local = square_to_uniform_cone(u, cos_max);
                        let w = Frame::from_normal(axis).to_world(local);
                        // Distance to the near side along w (pbrt-v4's construction).
                        let cos_t = local.z;
                        let sin2 = (1.0 - cos_t * cos_t).max(0.0);
                        let r2 = sphere.radius * sphere.radius;
                        let ds = dc * cos_t - (r2 - dc * dc * sin2).max(0.0).sqrt();
                        let q = p + w * ds;
                        let (q, n, _) = sphere.surface(q);
                        Some((q, n * sign, uniform_cone_pdf(cos_max)))
                    }
                    _ => {
                        let n = square_to_uniform_sphere(u);
                        let q = sphere.center + n * sphere.radius;
                        let pdf = area_to_solid_angle_at(p, q, n, 1.0 / sphere.area());
                        Some((q, n * sign, pdf))
                    }
                }
            }
            AreaShape::Rectangle { rect, flip } => {
                let q = rect.point(u);
                let n = if *flip { -rect.n } else { rect.n };
                Some((q, n, area_to_solid_angle_at(p, q, n, 1.0 / rect.area())))
            }
            AreaShape::Mesh { tris, cdf, area } => {
                let (i, _, ux) = cdf.sample(u.x);
                let (tri, n) = &tris[i];
                let b = square_to_uniform_triangle(Vec2::new(ux, u.y));
                let q = tri.point(b);
                Some((q, *n, area_to_solid_angle_at(p, q, *n, 1.0 / area)))
            }
        }
    }

    /// Solid-angle density of `sample` from `p` choosing point `q` with normal `n`.
    pub fn pdf(&self, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        match self {
            AreaShape::Sphere { sphere, .. } => match Self::sphere_cone(sphere, p) {
                Some((cos_max, _)) if cos_max < 0.99999 => uniform_cone_pdf(cos_max),
                _ => area_to_solid_angle_at(p, q, n, 1.0 / sphere.area()),
            },
            AreaShape::Rectangle { rect, .. } => area_to_solid_angle_at(p, q, n, 1.0 / rect.area()),
            AreaShape::Mesh { area, .. } => area_to_solid_angle_at(p, q, n, 1.0 / area),
        }
    }
}
