//! Unidirectional path tracing with next-event estimation and BSDF sampling combined by
//! multiple importance sampling with the power heuristic (Veach 1997, ch. 9), and Russian
//! roulette (Arvo and Kirk 1990) from depth `rr_depth` with continuation probability
//! min(max throughput, 0.95), as Mitsuba 3's `path` plugin does.
//!
//! Two forms compute the same radiance bit for bit: [`li`] here, one path at a time,
//! the reference the tests hold the renderer to, and the wavefront form the renderer
//! runs ([`Wavefront`](super::wavefront::Wavefront)), in which the samples of several pixels
//! go through each stage of a bounce together (tests/tests/wavefront.rs checks that they
//! agree).

use super::wavefront::DEPTH_CAP;
use super::{Shading, sample_one_light, unoccluded};
use crate::Rgb;
use crate::geometry::{Ray, spawn_ray};
use crate::sampler::Sampler;
use crate::scene::World;
use glam::Vec3;
use lobe_materials::sampling::warp::power_heuristic;

/// Radiance along `ray`, one path at a time (the reference form).
pub fn li(
    world: &World,
    mut ray: Ray,
    sampler: &mut Sampler,
    max_depth: Option<u32>,
    rr_depth: u32,
) -> Rgb {
    let max_depth = max_depth.unwrap_or(DEPTH_CAP).min(DEPTH_CAP);
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut depth = 0u32;
    let mut prev_pdf = 0.0f32;
    let mut prev_p = Vec3::ZERO;
    let sel_pdf = world.light_select_pdf();
    if max_depth == 0 {
        return l;
    }
    loop {
        let Some(it) = world.geometry.intersect(&ray) else {
            for &k in &world.infinite_lights {
                let light = &world.lights[k as usize];
                let (le, pdf) = light.le_pdf_infinite(ray.d);
                if le.is_black() {
                    continue;
                }
                let w = if depth == 0 {
                    1.0
                } else {
                    power_heuristic(prev_pdf, sel_pdf * pdf)
                };
                l += beta * le * w;
            }
            break;
        };
        let shape = &world.shapes[it.shape as usize];
        if let Some(k) = shape.light {
            let light = &world.lights[k as usize];
            let le = light.le_area(&it, -ray.d);
            if !le.is_black() {
                let w = if depth == 0 {
                    1.0
                } else {
                    power_heuristic(prev_pdf, sel_pdf * light.pdf_area(prev_p, &it))
                };
                l += beta * le * w;
            }
        }
        if depth + 1 >= max_depth {
            break;
        }
        let sh = Shading::new(world, &it, ray.d);
        // Next-event estimation.
        if let Some((ls, sel)) = sample_one_light(world, it.p, sampler) {
            let wi = sh.frame.to_local(ls.wi);
            let f = sh.bsdf.eval(sh.wo, wi) * wi.z.max(0.0);
            if !f.is_black() && unoccluded(world, &it, &ls) {
                let light_pdf = ls.pdf * sel;
                let w = if ls.delta {
                    1.0
                } else {
                    power_heuristic(light_pdf, sh.bsdf.pdf(sh.wo, wi))
                };
                l += beta * f * ls.li * (w / light_pdf);
            }
        }
        // BSDF sampling.
        let uc = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = sh.bsdf.sample(sh.wo, u, uc) else {
            break;
        };
        beta *= bs.weight;
        if beta.is_black() || !beta.is_finite() {
            break;
        }
        prev_pdf = bs.pdf;
        prev_p = it.p;
        ray = spawn_ray(&it, sh.frame.to_world(bs.wi));
        depth += 1;
        if depth >= rr_depth {
            let q = beta.max_component().min(0.95);
            if sampler.next_1d() >= q {
                break;
            }
            beta = beta / q;
        }
    }
    l
}
