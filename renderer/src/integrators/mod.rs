//! Integrators: `path` (unidirectional path tracing with next-event estimation and
//! multiple importance sampling) and `direct` (one bounce), both with Mitsuba 3's
//! semantics for depth and sample counts so that the same settings give the same
//! expected image in both renderers.

pub mod direct;
pub mod path;
pub mod wavefront;

pub use wavefront::Wavefront;

use crate::geometry::{Interaction, spawn_ray, spawn_ray_to};
use crate::lights::LightSample;
use crate::scene::World;
use crate::settings::Integrator;
use crate::{
    Rgb,
    geometry::{Ray, Rays},
    sampler::Sampler,
};
use glam::Vec3;
use lobe_materials::frame::{Frame, shading_axes};
use lobe_materials::simd;
use lobe_materials::simd::{LANES, Vec3xN};
use lobe_materials::{Bsdf, Vec3s};

impl Integrator {
    /// Radiance along a camera ray.
    #[inline]
    pub fn li(&self, world: &World, ray: Ray, sampler: &mut Sampler) -> Rgb {
        match *self {
            Integrator::Path {
                max_depth,
                rr_depth,
            } => path::li(world, ray, sampler, max_depth, rr_depth),
            Integrator::Direct {
                emitter_samples,
                bsdf_samples,
            } => direct::li(world, ray, sampler, emitter_samples, bsdf_samples),
        }
    }

    /// Radiance along many camera rays, `out[i]` for `rays[i]` with the sampler of sample
    /// `indices[i]` of the pixel with key `keys[i]` ([`Sampler::key_of`]; `sampler`: at
    /// the dimension the camera left it): the same values as [`Integrator::li`] of each,
    /// computed together (the path integrator's wavefront form, [`Wavefront::trace`],
    /// with the buffers of `wf`; the direct integrator's single bounce goes sample by
    /// sample).
    #[allow(clippy::too_many_arguments)] // the scalar `li`'s arguments, plus the batch's
    pub fn li_many(
        &self,
        world: &World,
        rays: &Rays,
        keys: &[u64],
        indices: &[u32],
        sampler: &mut Sampler,
        out: &mut [Rgb],
        wf: &mut Wavefront,
    ) {
        match *self {
            Integrator::Path {
                max_depth,
                rr_depth,
            } => wf.trace(
                world, rays, keys, indices, sampler, max_depth, rr_depth, out,
            ),
            Integrator::Direct { .. } => {
                for (j, ((o, &k), &i)) in out.iter_mut().zip(keys).zip(indices).enumerate() {
                    *o = self.li(world, rays.get(j), &mut sampler.with_sample(k, i));
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
    pub fn new(world: &'a World, it: &Interaction, ray_d: Vec3) -> Self {
        let frame = Frame::from_normal_tangent(it.ns, it.dpdu);
        let wo = frame.to_local(-ray_d).normalize();
        Self {
            bsdf: world.shapes[it.shape as usize].material.as_ref(),
            frame,
            wo,
        }
    }
}

/// [`Shading::new`]'s frames and local outgoing directions for `LANES` hits at once
/// (shading normals `ns`, tangents `dpdu`, ray directions `d`), bit for bit the same: the
/// lane instantiation of [`shading_axes`]; lanes whose tangent is degenerate take the
/// scalar fallback. Writes the frames' `s` and `t` (their `n` is `ns`) and the directions
/// of lanes `0..min(LANES, len - first)` to elements `first..` of the columns `out`
/// (`[s, t, wo]`, equally long), three plain stores each.
pub(crate) fn shading_lanes(
    ns: Vec3xN,
    dpdu: Vec3xN,
    d: Vec3xN,
    first: usize,
    out: [&mut Vec3s; 3],
) {
    let (s, t, wo, usable) = shading_axes(ns, dpdu, d);
    let [out_s, out_t, out_wo] = out;
    out_s.cols_mut().store(first, s);
    out_t.cols_mut().store(first, t);
    out_wo.cols_mut().store(first, wo);
    let usable = simd::mask_bits(usable);
    for i in 0..(out_wo.len() - first).min(LANES) {
        if usable >> i & 1 == 0 {
            let frame = Frame::from_normal_tangent(ns.lane(i), dpdu.lane(i));
            out_s.set(first + i, frame.s);
            out_t.set(first + i, frame.t);
            out_wo.set(first + i, frame.to_local(-d.lane(i)).normalize());
        }
    }
}

/// Samples one light uniformly (Mitsuba's emitter selection) and returns the sample,
/// the light's index and the selection probability, or None.
#[inline]
pub(crate) fn sample_one_light(
    world: &World,
    p: Vec3,
    sampler: &mut Sampler,
) -> Option<(LightSample, f32)> {
    let n = world.lights.len();
    let uc = sampler.next_1d();
    let u = sampler.next_2d();
    if n == 0 {
        return None;
    }
    let idx = ((uc * n as f32) as usize).min(n - 1);
    let ls = world.lights[idx].sample_li(p, u)?;
    if ls.li.is_black() || !(ls.pdf > 0.0) {
        return None;
    }
    Some((ls, world.light_select_pdf()))
}

/// True when the light sample `ls` is visible from `it`.
#[inline]
pub(crate) fn unoccluded(world: &World, it: &Interaction, ls: &LightSample) -> bool {
    !world.geometry.occluded(&shadow_ray(it, ls.wi, ls.p))
}

/// The shadow ray from `it` toward direction `wi`, up to the light point `at` (a point and
/// its normal, zero for none; None: at infinity), as [`LightSample::p`].
#[inline(always)]
pub(crate) fn shadow_ray(it: &Interaction, wi: Vec3, at: Option<(Vec3, Vec3)>) -> Ray {
    match at {
        Some((q, n)) => spawn_ray_to(it, q, if n == Vec3::ZERO { None } else { Some(n) }),
        None => spawn_ray(it, wi),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane frames equal `Frame::from_normal_tangent` and the normalized local
    /// `-d` bit for bit, including lanes with a degenerate tangent (zero, along the normal,
    /// NaN), which take the scalar fallback.
    #[test]
    fn shading_lanes_is_bit_identical() {
        let v = |k: usize, a: f32| {
            let t = k as f32 * a;
            Vec3::new(t.sin(), (1.7 * t).cos(), (0.3 * t).sin() + 0.2).normalize()
        };
        for round in 0..64 {
            let ns = simd::lanes(|i| v(round * LANES + i, 0.77));
            let dpdu = simd::lanes(|i| match (round + i) % 11 {
                0 => Vec3::ZERO,
                1 => ns[i] * 2.0,
                2 => Vec3::new(f32::NAN, 0.0, 1.0),
                _ => v(round * LANES + i, 1.31) * 3.0,
            });
            let d = simd::lanes(|i| -v(round * LANES + i, 0.53));
            let [mut fs, mut ft, mut wo] = [(); 3].map(|_| Vec3s::zeros(LANES + 1));
            let lanes = |v: &[Vec3; LANES]| Vec3xN::from_array(v);
            let first = round % 2;
            let out = [&mut fs, &mut ft, &mut wo];
            shading_lanes(lanes(&ns), lanes(&dpdu), lanes(&d), first, out);
            let untouched = if first == 0 { LANES } else { 0 };
            assert_eq!(wo.get(untouched), Vec3::ZERO, "LANES vectors from first");
            let [fs, ft, wo] = [&fs, &ft, &wo].map(|v| v.cols().slice(first..first + LANES));
            for i in 0..LANES {
                let f = Frame::from_normal_tangent(ns[i], dpdu[i]);
                let w = f.to_local(-d[i]).normalize();
                let bits =
                    |f: &Frame, w: Vec3| [f.s, f.t, f.n, w].map(|v| v.to_array().map(f32::to_bits));
                let frame = Frame {
                    s: fs.get(i),
                    t: ft.get(i),
                    n: ns[i],
                };
                assert_eq!(
                    bits(&frame, wo.get(i)),
                    bits(&f, w),
                    "lane {i} of round {round}"
                );
            }
        }
    }
}
