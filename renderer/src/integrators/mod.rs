//! Integrators: `path` (unidirectional path tracing with next-event estimation and
//! multiple importance sampling) and `direct` (one bounce), both with Mitsuba 3's
//! semantics for depth and sample counts so that the same settings give the same
//! expected image in both renderers.

pub mod direct;
pub mod path;

use crate::geometry::{Interaction, spawn_ray, spawn_ray_to};
use crate::lights::LightSample;
use crate::scene::Scene;
use crate::{Rgb, geometry::Ray, sampler::Sampler};
use glam::Vec3;
use lobe_materials::Bsdf;
use lobe_materials::frame::Frame;

/// Which light transport algorithm renders the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    /// `max_depth`: longest path in vertices, Mitsuba's meaning: 1 shows only directly
    /// visible emitters, 2 adds direct illumination; `None` is unbounded.
    /// Russian roulette starts at path depth `rr_depth`.
    Path {
        max_depth: Option<u32>,
        rr_depth: u32,
    },
    /// Direct illumination with `emitter_samples` light samples and `bsdf_samples` BSDF
    /// samples per hit, combined with the power heuristic (Mitsuba's `direct`).
    Direct {
        emitter_samples: u32,
        bsdf_samples: u32,
    },
}

impl Integrator {
    /// Radiance along a camera ray.
    #[inline]
    pub fn li(&self, scene: &Scene, ray: Ray, sampler: &mut Sampler) -> Rgb {
        match *self {
            Integrator::Path {
                max_depth,
                rr_depth,
            } => path::li(scene, ray, sampler, max_depth, rr_depth),
            Integrator::Direct {
                emitter_samples,
                bsdf_samples,
            } => direct::li(scene, ray, sampler, emitter_samples, bsdf_samples),
        }
    }

    /// Radiance along many camera rays of one pixel, `out[i]` for `rays[i]` with the
    /// sampler of sample `indices[i]` (`sampler`: the pixel's, at the dimension the camera
    /// left it): the same values as [`Integrator::li`] of each, computed together (the
    /// path integrator's wavefront form, [`path::li_many`]).
    pub fn li_many(
        &self,
        scene: &Scene,
        rays: &[Ray],
        indices: &[u32],
        sampler: &mut Sampler,
        out: &mut [Rgb],
        ws: &mut path::Workspace,
    ) {
        match *self {
            Integrator::Path {
                max_depth,
                rr_depth,
            } => path::li_many(scene, rays, indices, sampler, max_depth, rr_depth, out, ws),
            Integrator::Direct { .. } => {
                for ((o, &ray), &i) in out.iter_mut().zip(rays).zip(indices) {
                    *o = self.li(scene, ray, &mut sampler.with_index(i));
                }
            }
        }
    }

    pub fn describe(&self) -> String {
        match self {
            Integrator::Path {
                max_depth,
                rr_depth,
            } => format!(
                "path (max_depth {}, rr_depth {rr_depth})",
                max_depth.map_or("unbounded".to_string(), |d| d.to_string())
            ),
            Integrator::Direct {
                emitter_samples,
                bsdf_samples,
            } => {
                format!("direct (emitter_samples {emitter_samples}, bsdf_samples {bsdf_samples})")
            }
        }
    }
}

/// The BSDF and shading frame at a hit.
pub(crate) struct Shading<'a> {
    pub bsdf: &'a dyn Bsdf,
    pub frame: Frame,
    pub wo: Vec3,
}

impl<'a> Shading<'a> {
    #[inline]
    pub fn new(scene: &'a Scene, it: &Interaction, ray_d: Vec3) -> Self {
        let frame = Frame::from_normal_tangent(it.ns, it.dpdu);
        let wo = frame.to_local(-ray_d).normalize();
        Self {
            bsdf: scene.shapes[it.shape as usize].material.as_ref(),
            frame,
            wo,
        }
    }
}

/// Samples one light uniformly (Mitsuba's emitter selection) and returns the sample,
/// the light's index and the selection probability, or None.
#[inline]
pub(crate) fn sample_one_light(
    scene: &Scene,
    p: Vec3,
    sampler: &mut Sampler,
) -> Option<(LightSample, f32)> {
    let n = scene.lights.len();
    let uc = sampler.next_1d();
    let u = sampler.next_2d();
    if n == 0 {
        return None;
    }
    let idx = ((uc * n as f32) as usize).min(n - 1);
    let ls = scene.lights[idx].sample_li(p, u)?;
    if ls.li.is_black() || !(ls.pdf > 0.0) {
        return None;
    }
    Some((ls, 1.0 / n as f32))
}

/// True when the light sample `ls` is visible from `it`.
#[inline]
pub(crate) fn unoccluded(scene: &Scene, it: &Interaction, ls: &LightSample) -> bool {
    unoccluded_to(scene, it, ls.wi, ls.p)
}

/// True when nothing blocks direction `wi` from `it` up to the light point `at` (a point
/// and its normal, zero for none; None: at infinity), as [`LightSample::p`].
#[inline]
pub(crate) fn unoccluded_to(
    scene: &Scene,
    it: &Interaction,
    wi: Vec3,
    at: Option<(Vec3, Vec3)>,
) -> bool {
    !scene.geometry.occluded(&shadow_ray(it, wi, at))
}

/// The shadow ray [`unoccluded_to`] tests.
#[inline]
pub(crate) fn shadow_ray(it: &Interaction, wi: Vec3, at: Option<(Vec3, Vec3)>) -> Ray {
    match at {
        Some((q, n)) => spawn_ray_to(it, q, if n == Vec3::ZERO { None } else { Some(n) }),
        None => spawn_ray(it, wi),
    }
}
