//! Unidirectional path tracing with next-event estimation and BSDF sampling combined by
//! multiple importance sampling with the power heuristic (Veach 1997, ch. 9), and Russian
//! roulette (Arvo and Kirk 1990) from depth `rr_depth` with continuation probability
//! min(max throughput, 0.95), as Mitsuba 3's `path` plugin does.
//!
//! Two forms compute the same radiance bit for bit: [`li`], one path at a time (the
//! reference, behind `Integrator::li`), and [`li_many`], the wavefront
//! form the renderer runs, in which the samples of a pixel go through each stage of a
//! bounce together (tests/tests/wavefront.rs checks that they agree).

use super::{Shading, sample_one_light, shading_x8, shadow_ray, unoccluded};
use crate::Rgb;
use crate::geometry::{Interaction, Ray, spawn_ray};
use crate::lights::Light;
use crate::sampler::Sampler;
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use lobe_materials::BsdfSample;
use lobe_materials::frame::Frame;
use lobe_materials::sampling::power_heuristic;
use lobe_materials::simd;

/// Hard cap on path length when `max_depth` is unbounded (Russian roulette ends paths
/// long before; this only guards against pathological scenes).
const DEPTH_CAP: u32 = 1 << 16;

pub fn li(
    scene: &Scene,
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
    let sel_pdf = if scene.lights.is_empty() {
        0.0
    } else {
        1.0 / scene.lights.len() as f32
    };
    if max_depth == 0 {
        return l;
    }
    loop {
        let Some(it) = scene.geometry.intersect(&ray) else {
            for &k in &scene.infinite_lights {
                let light = &scene.lights[k as usize];
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
        let shape = &scene.shapes[it.shape as usize];
        if let Some(k) = shape.light {
            let light = &scene.lights[k as usize];
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
        let sh = Shading::new(scene, &it, ray.d);
        // Next-event estimation.
        if let Some((ls, sel)) = sample_one_light(scene, it.p, sampler) {
            let wi = sh.frame.to_local(ls.wi);
            let f = sh.bsdf.eval(sh.wo, wi) * wi.z.max(0.0);
            if !f.is_black() && unoccluded(scene, &it, &ls) {
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

/// The state of one path of [`li_many`] between bounces, besides its ray.
#[derive(Clone, Copy)]
struct PathVars {
    beta: Rgb,
    l: Rgb,
    prev_p: Vec3,
    prev_pdf: f32,
    depth: u32,
}

impl PathVars {
    const START: Self = Self {
        beta: Rgb::ONE,
        l: Rgb::ZERO,
        prev_p: Vec3::ZERO,
        prev_pdf: 0.0,
        depth: 0,
    };
}

/// Buffers of [`li_many`], kept between calls so that a tile allocates them once. Data
/// passed between stages is kept in flat arrays of plain values (no per-element `Option`
/// or packed records), which the stages read and write with straight loads and stores.
#[derive(Default)]
pub struct Workspace {
    /// Per path: its ray and the rest of its state.
    rays: Vec<Ray>,
    vars: Vec<PathVars>,
    active: Vec<u32>,
    next: Vec<u32>,
    /// Per active path: its closest hit.
    closest: Vec<Option<(f32, u32)>>,
    /// The hits of this bounce: (path, t, primitive).
    hits: Vec<(u32, f32, u32)>,
    /// The paths that hit a surface this bounce and go on, and their interactions.
    hit_paths: Vec<u32>,
    its: Vec<Interaction>,
    /// Escaped paths and their directions, and the env-map values there.
    escaped: Vec<u32>,
    dirs: Vec<Vec3>,
    env_eval: Vec<(Rgb, f32)>,
    /// Per hit: shading frame, local outgoing direction, and BSDF sample.
    frames: Vec<Frame>,
    wo: Vec<Vec3>,
    bsdf_samples: Vec<Option<BsdfSample>>,
    /// Per hit: its light sample's local direction, and the BSDF's value and pdf there.
    ls_local: Vec<Vec3>,
    ls_f: Vec<Rgb>,
    ls_bsdf_pdf: Vec<f32>,
    /// Runs of consecutive hits on the same shape: (first, end), one batched BSDF call
    /// each.
    runs: Vec<(usize, usize)>,
    /// Light samples the BSDF reflects: (hit, BSDF value x cosine, local direction), and
    /// their shadow rays and whether they are blocked.
    nee: Vec<(u32, Rgb, Vec3)>,
    shadow_rays: Vec<Ray>,
    occluded: Vec<bool>,
    /// Sample indices of a list of paths, and the sampler values drawn for them.
    lane_index: Vec<u32>,
    nee_uc: Vec<f32>,
    nee_u: Vec<Vec2>,
    bsdf_uc: Vec<f32>,
    bsdf_u: Vec<Vec2>,
    /// Per hit, its light sample: direction, radiance, solid-angle pdf (0: no sample),
    /// whether it is a delta light, and the point on the light
    /// ([`LightSample::p`](crate::lights::LightSample::p)).
    ls_wi: Vec<Vec3>,
    ls_li: Vec<Rgb>,
    ls_pdf: Vec<f32>,
    ls_delta: Vec<bool>,
    ls_at: Vec<Option<(Vec3, Vec3)>>,
    /// Light-sample requests to env maps when the scene has other lights too: (hit, light
    /// index), point, and the samples.
    env_lanes: Vec<(u32, u32)>,
    env_u: Vec<Vec2>,
    env_wi: Vec<Vec3>,
    env_li: Vec<Rgb>,
    env_pdf: Vec<f32>,
}

/// [`li`] of many camera rays of one pixel at once, `out[i]` for `rays[i]` with the
/// sampler of sample `indices[i]` (`sampler` holds the pixel and the dimension the camera
/// left it at), bit for bit the same: a wavefront formulation (Laine, Karras and Aila, "Megakernels Considered
/// Harmful", 2013; pbrt-v4's `WavefrontPathIntegrator`) in which every bounce runs stage
/// by stage over all live paths. Each path makes exactly the scalar integrator's
/// operations in the same order (so the same sampler dimensions and the same sums), but
/// the environment-map lookups of all escaping rays and the environment-map light samples
/// of all hits run as batches ([`EnvMap::eval_pdf_many`], [`EnvMap::sample_many`]),
/// whose independent lookups overlap instead of forming one long dependency chain per
/// path. All live paths are at the same depth, so they are at the same sampler dimension
/// too, and each dimension is drawn for all of them at once ([`Sampler::next_1d_lanes`]).
///
/// [`EnvMap::eval_pdf_many`]: crate::lights::EnvMap::eval_pdf_many
/// [`EnvMap::sample_many`]: crate::lights::EnvMap::sample_many
#[allow(clippy::too_many_arguments)] // the scalar `li`'s arguments, plus the batch's
pub fn li_many(
    scene: &Scene,
    rays: &[Ray],
    indices: &[u32],
    sampler: &mut Sampler,
    max_depth: Option<u32>,
    rr_depth: u32,
    out: &mut [Rgb],
    ws: &mut Workspace,
) {
    assert!(rays.len() == indices.len() && rays.len() == out.len());
    let max_depth = max_depth.unwrap_or(DEPTH_CAP).min(DEPTH_CAP);
    let n_lights = scene.lights.len();
    let sel_pdf = if n_lights == 0 {
        0.0
    } else {
        1.0 / n_lights as f32
    };
    ws.rays.clear();
    ws.rays.extend_from_slice(rays);
    ws.vars.clear();
    ws.vars.resize(rays.len(), PathVars::START);
    ws.active.clear();
    if max_depth > 0 {
        ws.active.extend(0..rays.len() as u32);
    }
    // A scene lit by one env map alone samples it for every hit, in one batch.
    let env_only = match scene.lights.as_slice() {
        [Light::Env(env)] => Some(env),
        _ => None,
    };
    while !ws.active.is_empty() {
        // Intersection: the closest hits of all paths, then the local geometry of the hits
        // (two passes, so that neither waits on the other's long dependency chains).
        ws.closest.clear();
        scene
            .geometry
            .closest_many(&ws.rays, &ws.active, &mut ws.closest);
        // Escaped paths, and hits: emission of the surfaces hit, then the paths that go on
        // in a compact list (`its[h]` is the interaction of path `hit_paths[h]`).
        ws.escaped.clear();
        ws.hits.clear();
        for (&i, c) in ws.active.iter().zip(&ws.closest) {
            match *c {
                Some((t, prim)) => ws.hits.push((i, t, prim)),
                None => ws.escaped.push(i),
            }
        }
        ws.its.clear();
        scene
            .geometry
            .interactions_many(&ws.rays, &ws.hits, &mut ws.its);
        // Emission. All live paths share their depth (they start together and each
        // bounce moves them on by one), so either every hit goes on or none does.
        let goes_on = ws.vars[ws.active[0] as usize].depth + 1 < max_depth;
        for (&(i, _, _), it) in ws.hits.iter().zip(&ws.its) {
            let ray = &ws.rays[i as usize];
            let p = &mut ws.vars[i as usize];
            debug_assert_eq!(p.depth + 1 < max_depth, goes_on, "paths share their depth");
            if let Some(k) = scene.shapes[it.shape as usize].light {
                let light = &scene.lights[k as usize];
                let le = light.le_area(it, -ray.d);
                if !le.is_black() {
                    let w = if p.depth == 0 {
                        1.0
                    } else {
                        power_heuristic(p.prev_pdf, sel_pdf * light.pdf_area(p.prev_p, it))
                    };
                    p.l += p.beta * le * w;
                }
            }
        }
        ws.hit_paths.clear();
        if goes_on {
            ws.hit_paths.extend(ws.hits.iter().map(|&(i, _, _)| i));
        } else {
            ws.its.clear();
        }
        // Escaped paths gather the infinite lights; env maps in one batch per light.
        if !ws.escaped.is_empty() {
            ws.dirs.clear();
            ws.dirs
                .extend(ws.escaped.iter().map(|&i| ws.rays[i as usize].d));
            for &k in &scene.infinite_lights {
                let light = &scene.lights[k as usize];
                ws.env_eval.clear();
                if let Light::Env(env) = light {
                    ws.env_eval.resize(ws.dirs.len(), (Rgb::ZERO, 0.0));
                    env.eval_pdf_many(&ws.dirs, &mut ws.env_eval);
                } else {
                    ws.env_eval
                        .extend(ws.dirs.iter().map(|&d| light.le_pdf_infinite(d)));
                }
                for (&i, &(le, pdf)) in ws.escaped.iter().zip(&ws.env_eval) {
                    if le.is_black() {
                        continue;
                    }
                    let p = &mut ws.vars[i as usize];
                    let w = if p.depth == 0 {
                        1.0
                    } else {
                        power_heuristic(p.prev_pdf, sel_pdf * pdf)
                    };
                    p.l += p.beta * le * w;
                }
            }
        }
        let m = ws.hit_paths.len();
        if m == 0 {
            break;
        }
        // The sampler dimensions of this bounce for every path that goes on: light choice
        // and point, BSDF lobe and direction (Russian roulette's comes below).
        ws.lane_index.clear();
        ws.lane_index
            .extend(ws.hit_paths.iter().map(|&i| indices[i as usize]));
        ws.nee_uc.resize(m, 0.0);
        ws.nee_u.resize(m, Vec2::ZERO);
        ws.bsdf_uc.resize(m, 0.0);
        ws.bsdf_u.resize(m, Vec2::ZERO);
        sampler.next_1d_lanes(&ws.lane_index, &mut ws.nee_uc);
        sampler.next_2d_lanes(&ws.lane_index, &mut ws.nee_u);
        sampler.next_1d_lanes(&ws.lane_index, &mut ws.bsdf_uc);
        sampler.next_2d_lanes(&ws.lane_index, &mut ws.bsdf_u);
        // Light samples (`ls_*[h]` for hit h): env maps in batches, other lights one by one.
        ws.ls_wi.resize(m, Vec3::ZERO);
        ws.ls_li.resize(m, Rgb::ZERO);
        ws.ls_pdf.clear();
        ws.ls_pdf.resize(m, 0.0);
        ws.ls_delta.clear();
        ws.ls_delta.resize(m, false);
        ws.ls_at.clear();
        ws.ls_at.resize(m, None);
        if let Some(env) = env_only {
            env.sample_many(&ws.nee_u, &mut ws.ls_wi, &mut ws.ls_li, &mut ws.ls_pdf);
        } else if n_lights > 0 {
            ws.env_lanes.clear();
            ws.env_u.clear();
            for (h, it) in ws.its.iter().enumerate() {
                let idx = ((ws.nee_uc[h] * n_lights as f32) as usize).min(n_lights - 1);
                let u = ws.nee_u[h];
                match &scene.lights[idx] {
                    Light::Env(_) => {
                        ws.env_lanes.push((h as u32, idx as u32));
                        ws.env_u.push(u);
                    }
                    light => {
                        if let Some(ls) = light.sample_li(it.p, u) {
                            ws.ls_wi[h] = ls.wi;
                            ws.ls_li[h] = ls.li;
                            ws.ls_pdf[h] = ls.pdf;
                            ws.ls_delta[h] = ls.delta;
                            ws.ls_at[h] = ls.p;
                        }
                    }
                }
            }
            if !ws.env_lanes.is_empty() {
                let e = ws.env_lanes.len();
                ws.env_wi.resize(e, Vec3::ZERO);
                ws.env_li.resize(e, Rgb::ZERO);
                ws.env_pdf.resize(e, 0.0);
                // Several env maps are sampled one after another, each in a batch.
                let first = ws.env_lanes[0].1;
                if ws.env_lanes.iter().all(|&(_, k)| k == first) {
                    if let Light::Env(env) = &scene.lights[first as usize] {
                        env.sample_many(&ws.env_u, &mut ws.env_wi, &mut ws.env_li, &mut ws.env_pdf);
                    }
                } else {
                    for (q, &(_, k)) in ws.env_lanes.iter().enumerate() {
                        if let Light::Env(env) = &scene.lights[k as usize] {
                            (ws.env_wi[q], ws.env_li[q], ws.env_pdf[q]) = env
                                .sample(ws.env_u[q])
                                .unwrap_or((Vec3::ZERO, Rgb::ZERO, 0.0));
                        }
                    }
                }
                for (q, &(h, _)) in ws.env_lanes.iter().enumerate() {
                    let h = h as usize;
                    (ws.ls_wi[h], ws.ls_li[h], ws.ls_pdf[h]) =
                        (ws.env_wi[q], ws.env_li[q], ws.env_pdf[q]);
                }
            }
        }
        // Shading frames, then next-event estimation: BSDF values, shadow rays, sums.
        // (Eight hits at a time in SIMD lanes: `shading_x8`, bit for bit `Shading::new`.)
        ws.frames.clear();
        ws.wo.clear();
        for (ic, pc) in ws.its.chunks(8).zip(ws.hit_paths.chunks(8)) {
            let n = ic.len();
            let (frames, wo) = shading_x8(
                simd::lanes(|k| ic[k.min(n - 1)].ns),
                simd::lanes(|k| ic[k.min(n - 1)].dpdu),
                simd::lanes(|k| ws.rays[pc[k.min(n - 1)] as usize].d),
            );
            ws.frames.extend_from_slice(&frames[..n]);
            ws.wo.extend_from_slice(&wo[..n]);
        }
        // Runs of hits on one shape, for batched BSDF calls.
        ws.runs.clear();
        let mut a = 0;
        while a < m {
            let shape = ws.its[a].shape;
            let b = a + ws.its[a..]
                .iter()
                .take_while(|it| it.shape == shape)
                .count();
            ws.runs.push((a, b));
            a = b;
        }
        // BSDF values and pdfs of every hit's light sample, one call per run (for hits
        // without a sample, pdf 0, the direction is whatever the buffer held: their values
        // are not used).
        ws.ls_local.clear();
        ws.ls_local.extend(
            ws.frames
                .iter()
                .zip(&ws.ls_wi)
                .map(|(frame, &wi)| frame.to_local(wi)),
        );
        ws.ls_f.resize(m, Rgb::ZERO);
        ws.ls_bsdf_pdf.resize(m, 0.0);
        for &(a, b) in &ws.runs {
            scene.shapes[ws.its[a].shape as usize]
                .material
                .eval_pdf_many(
                    &ws.wo[a..b],
                    &ws.ls_local[a..b],
                    &mut ws.ls_f[a..b],
                    &mut ws.ls_bsdf_pdf[a..b],
                );
        }
        // Samples the BSDF reflects are kept by a branch-free compaction: whether a light
        // sample lies above the surface is a coin flip a branch would mispredict. A light
        // sample counts when its pdf is positive and its radiance is not black.
        ws.nee.clear();
        ws.nee.resize(m, (0, Rgb::ZERO, Vec3::ZERO));
        let mut kept = 0;
        for (h, ((&wi, &f), (&pdf, li))) in ws
            .ls_local
            .iter()
            .zip(&ws.ls_f)
            .zip(ws.ls_pdf.iter().zip(&ws.ls_li))
            .enumerate()
        {
            if !(pdf > 0.0) || li.is_black() {
                continue;
            }
            let f = f * wi.z.max(0.0);
            ws.nee[kept] = (h as u32, f, wi);
            kept += !f.is_black() as usize;
        }
        ws.nee.truncate(kept);
        // Shadow rays of all of them, tested together.
        ws.shadow_rays.clear();
        ws.shadow_rays.extend(ws.nee.iter().map(|&(h, _, _)| {
            let h = h as usize;
            shadow_ray(&ws.its[h], ws.ls_wi[h], ws.ls_at[h])
        }));
        ws.occluded.clear();
        scene
            .geometry
            .occluded_many(&ws.shadow_rays, &mut ws.occluded);
        for (&(h, f, _), &occluded) in ws.nee.iter().zip(&ws.occluded) {
            if occluded {
                continue;
            }
            let h = h as usize;
            let light_pdf = ws.ls_pdf[h] * sel_pdf;
            let w = if ws.ls_delta[h] {
                1.0
            } else {
                power_heuristic(light_pdf, ws.ls_bsdf_pdf[h])
            };
            let p = &mut ws.vars[ws.hit_paths[h] as usize];
            p.l += p.beta * f * ws.ls_li[h] * (w / light_pdf);
        }
        // BSDF sampling: one batched call per run of hits on the same shape.
        ws.bsdf_samples.clear();
        ws.bsdf_samples.resize(m, None);
        for &(a, b) in &ws.runs {
            scene.shapes[ws.its[a].shape as usize].material.sample_many(
                &ws.wo[a..b],
                &ws.bsdf_u[a..b],
                &ws.bsdf_uc[a..b],
                &mut ws.bsdf_samples[a..b],
            );
        }
        ws.next.clear();
        let mut depth = 0;
        for (((it, frame), bs), &i) in ws
            .its
            .iter()
            .zip(&ws.frames)
            .zip(&ws.bsdf_samples)
            .zip(&ws.hit_paths)
        {
            let Some(bs) = bs else {
                continue;
            };
            let p = &mut ws.vars[i as usize];
            p.beta *= bs.weight;
            if p.beta.is_black() || !p.beta.is_finite() {
                continue;
            }
            p.prev_pdf = bs.pdf;
            p.prev_p = it.p;
            p.depth += 1;
            depth = p.depth;
            ws.rays[i as usize] = spawn_ray(it, frame.to_world(bs.wi));
            ws.next.push(i);
        }
        // Russian roulette, one dimension for all paths (they share their depth).
        if depth >= rr_depth && !ws.next.is_empty() {
            ws.lane_index.clear();
            ws.lane_index
                .extend(ws.next.iter().map(|&i| indices[i as usize]));
            ws.nee_uc.resize(ws.next.len(), 0.0);
            sampler.next_1d_lanes(&ws.lane_index, &mut ws.nee_uc[..ws.next.len()]);
            let mut kept = 0;
            for j in 0..ws.next.len() {
                let i = ws.next[j];
                let p = &mut ws.vars[i as usize];
                let q = p.beta.max_component().min(0.95);
                if ws.nee_uc[j] >= q {
                    continue;
                }
                p.beta = p.beta / q;
                ws.next[kept] = i;
                kept += 1;
            }
            ws.next.truncate(kept);
        }
        std::mem::swap(&mut ws.active, &mut ws.next);
    }
    for (o, p) in out.iter_mut().zip(&ws.vars) {
        *o = p.l;
    }
}
