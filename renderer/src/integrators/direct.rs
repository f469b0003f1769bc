//! Direct illumination only (one bounce), for pure BRDF comparisons: emitters seen by the
//! camera, plus at the first hit `emitter_samples` light samples and `bsdf_samples` BSDF
//! samples combined with the power heuristic using the sample counts, as Mitsuba 3's
//! `direct` plugin does (Veach 1997, eq. 9.13 with n_i samples per strategy).

use super::{Shading, sample_one_light, unoccluded};
use crate::Rgb;
use crate::geometry::{Ray, spawn_ray};
use crate::sampler::Sampler;
use crate::scene::World;
use lobe_materials::sampling::warp::power_heuristic;

pub fn li(
    world: &World,
    ray: Ray,
    sampler: &mut Sampler,
    emitter_samples: u32,
    bsdf_samples: u32,
) -> Rgb {
    let mut l = Rgb::ZERO;
    let Some(it) = world.geometry.intersect(&ray) else {
        for &k in &world.infinite_lights {
            l += world.lights[k as usize].le_infinite(ray.d);
        }
        return l;
    };
    let shape = &world.shapes[it.shape as usize];
    if let Some(k) = shape.light {
        l += world.lights[k as usize].le_area(&it, -ray.d);
    }
    let sh = Shading::new(world, &it, ray.d);
    let total = (emitter_samples + bsdf_samples) as f32;
    let frac_em = emitter_samples as f32 / total;
    let frac_bsdf = bsdf_samples as f32 / total;
    let sel_pdf = world.light_select_pdf();

    for _ in 0..emitter_samples {
        if let Some((ls, sel)) = sample_one_light(world, it.p, sampler) {
            let wi = sh.frame.to_local(ls.wi);
            let f = sh.bsdf.eval(sh.wo, wi) * wi.z.max(0.0);
            if !f.is_black() && unoccluded(world, &it, &ls) {
                let light_pdf = ls.pdf * sel;
                let w = if ls.delta {
                    1.0
                } else {
                    power_heuristic(light_pdf * frac_em, sh.bsdf.pdf(sh.wo, wi) * frac_bsdf)
                };
                l += f * ls.li * (w / (light_pdf * emitter_samples as f32));
            }
        }
    }
    for _ in 0..bsdf_samples {
        let uc = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = sh.bsdf.sample(sh.wo, u, uc) else {
            continue;
        };
        let wi = sh.frame.to_world(bs.wi);
        let r = spawn_ray(&it, wi);
        // Each light is its own integrand term, weighted with its own density.
        let mut add = |le: Rgb, light_pdf: f32| {
            if !le.is_black() {
                let w = power_heuristic(bs.pdf * frac_bsdf, light_pdf * frac_em);
                l += bs.weight * le * (w / bsdf_samples as f32);
            }
        };
        match world.geometry.intersect(&r) {
            None => {
                for &k in &world.infinite_lights {
                    let (le, pdf) = world.lights[k as usize].le_pdf_infinite(wi);
                    add(le, sel_pdf * pdf);
                }
            }
            Some(hit) => {
                if let Some(k) = world.shapes[hit.shape as usize].light {
                    let light = &world.lights[k as usize];
                    add(
                        light.le_area(&hit, -wi),
                        sel_pdf * light.pdf_area(it.p, &hit),
                    );
                }
            }
        }
    }
    l
}
