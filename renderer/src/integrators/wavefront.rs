//! The wavefront form of the path integrator, the one the renderer runs: the camera
//! samples of several pixels are traced together, and every bounce runs stage by stage over all
//! live paths, each stage one method over typed struct-of-arrays queues (pbrt-v4's
//! `WavefrontPathIntegrator`, `src/pbrt/wavefront/integrator.h`; Laine, Karras and Aila,
//! "Megakernels Considered Harmful: Wavefront Path Tracing on GPUs", 2013):
//!
//! | stage | reads | writes |
//! |---|---|---|
//! | [`CameraQueue::push_pixel`] | camera, sampler | camera rays |
//! | [`Wavefront::intersect`] | active paths' rays | [`HitQueue`], [`EscapedQueue`] |
//! | [`Wavefront::escaped`] | escaped paths' directions | radiance of infinite lights |
//! | [`Wavefront::emission`] | hits | radiance of area lights hit |
//! | [`Wavefront::scatter_setup`] | hits that go on | [`ScatterQueue`]: frames, sampler values, material groups |
//! | [`Wavefront::light_samples`] | scatter queue | [`LightSampleQueue`] (one batch per light) |
//! | [`Wavefront::bsdf_eval`] | light samples | BSDF values and pdfs (one batch per material) |
//! | [`Wavefront::shadow_rays`] | light samples | [`ShadowQueue`], radiance of unoccluded samples |
//! | [`Wavefront::bsdf_samples`] | scatter queue | BSDF samples (one batch per material) |
//! | [`Wavefront::spawn`] | BSDF samples | Russian roulette, then the next bounce's rays in order |
//!
//! Each path makes exactly the operations of the scalar [`path::li`](super::path::li) in
//! the same order (the same sampler dimensions and the same sums), so the two agree bit
//! for bit (tests/tests/wavefront.rs); what the stages add is that the independent work of
//! many paths runs as batches: the lights' and the materials' batched calls
//! ([`Light::sample_li_many`], [`Bsdf::eval_pdf_many`], [`Bsdf::sample_many`]) on all
//! requests to one light or one material, and the geometry's batched queries. All live
//! paths start together and each bounce moves them on by one, so they share their depth
//! and their sampler dimension, drawn for all at once ([`Sampler::next_1d_lanes`]).

use super::{shading_lanes, shadow_ray};
use crate::Rgb;
use crate::camera::Camera;
use crate::geometry::{Interactions, Rays};
#[cfg(doc)]
use crate::lights::Light;
use crate::lights::LightSamples;
use crate::sampler::Sampler;
use crate::scene::World;
use glam::{Vec2, Vec3};
use lobe_materials::frame;
use lobe_materials::grouping::group_stable;
use lobe_materials::sampling::warp::power_heuristic;
use lobe_materials::simd;
use lobe_materials::simd::LANES;
use lobe_materials::{Bsdf, BsdfSamples, BsdfSamplesMut, Vec2Cols, Vec2s, Vec3Cols, Vec3s};

/// Hard cap on path length when `max_depth` is unbounded (Russian roulette ends paths
/// long before; this only guards against pathological scenes).
pub const DEPTH_CAP: u32 = 1 << 16;

/// The state of the wavefront's paths: the rays of the live ones, in the order of
/// [`Wavefront::active`] (ray j is path `active[j]`'s, so the geometry's batched queries
/// read them as consecutive columns); and, indexed by path, each path's other variables
/// (one record per path: the stages reach paths through the queues' indices, and one
/// record is one cache line) and its sampler stream: its pixel's key
/// ([`Sampler::key_of`]) and its sample index within the pixel.
#[derive(Default)]
pub struct Paths {
    pub ray: Rays,
    pub vars: Vec<PathVars>,
    pub key: Vec<u64>,
    pub index: Vec<u32>,
}

/// A path's throughput, radiance so far, and previous vertex and its BSDF density (for
/// the MIS weights of emitters that BSDF sampling hits).
#[derive(Clone, Copy, Debug)]
pub struct PathVars {
    pub beta: Rgb,
    pub l: Rgb,
    pub prev_p: Vec3,
    pub prev_pdf: f32,
}

impl PathVars {
    const START: Self = Self {
        beta: Rgb::ONE,
        l: Rgb::ZERO,
        prev_p: Vec3::ZERO,
        prev_pdf: 0.0,
    };
}

/// The closest hits of a bounce.
#[derive(Default)]
pub struct HitQueue {
    /// Per hit h, its path.
    pub path: Vec<u32>,
    /// Per ray j of [`Paths::ray`], its closest hit (distance, primitive), misses included.
    pub closest: Vec<Option<(f32, u32)>>,
    /// Per hit h, (j, t, prim): the index of its ray in [`Paths::ray`] (a queue position,
    /// not a path; increasing in h), its distance and primitive.
    pub hits: Vec<(u32, f32, u32)>,
    /// Per hit h, its local geometry.
    pub it: Interactions,
}

/// Paths whose ray left the scene, their directions, and an infinite light's value and
/// density there.
#[derive(Default)]
pub struct EscapedQueue {
    /// The escaped paths.
    pub path: Vec<u32>,
    /// Per escaped path, the index of its ray in [`Paths::ray`] (a queue position, not a
    /// path).
    pub ray_index: Vec<u32>,
    /// Per escaped path, its ray's direction, gathered once the paths are sorted out
    /// ([`Wavefront::spawn`] overwrites the ray queue).
    pub dir: Vec3s,
    /// Per escaped path, an infinite light's radiance and density along `dir`.
    pub le_pdf: Vec<(Rgb, f32)>,
}

/// The hits that scatter (paths that go on), indexed like [`HitQueue::it`]: the tangents
/// of their shading frames (the frame of hit h is element h of `frame_s` and `frame_t`
/// and the hit's `ns`), local outgoing directions (columns, as the tangents), this
/// bounce's sampler values, and the hits grouped by material.
#[derive(Default)]
pub struct ScatterQueue {
    pub frame_s: Vec3s,
    pub frame_t: Vec3s,
    pub wo: Vec3s,
    pub sample_key: Vec<u64>,
    pub sample_index: Vec<u32>,
    pub light_uc: Vec<f32>,
    pub light_u: Vec2s,
    pub bsdf_uc: Vec<f32>,
    pub bsdf_u: Vec2s,
    pub groups: MaterialGroups,
}

/// Light samples of the scattering hits, indexed like them ([`LightSamples`]: pdf 0 for
/// none), then the local direction and the BSDF's value and density there.
#[derive(Default)]
pub struct LightSampleQueue {
    pub samples: LightSamples,
    pub wi_local: Vec3s,
    pub f: Vec<Rgb>,
    pub bsdf_pdf: Vec<f32>,
    /// Requests grouped by light: hit indices, ordered by light, and where each light's
    /// run of them starts ([`group_stable`]); one light's batch of points, samples and
    /// results.
    order: Vec<u32>,
    starts: Vec<usize>,
    p: Vec3s,
    u: Vec2s,
    batch: LightSamples,
}

/// Light samples the BSDF reflects: hit, BSDF value times cosine, shadow ray, and
/// whether it is blocked.
#[derive(Default)]
pub struct ShadowQueue {
    pub hit: Vec<u32>,
    pub f: Vec<Rgb>,
    pub ray: Rays,
    pub occluded: Vec<bool>,
}

/// Hits grouped by material, for the materials' batched calls: `order` lists hit indices
/// material by material (stable), `ranges` each material's span of it; `contiguous` when
/// `order` is the identity (hits already grouped), so the batches read the queues in
/// place.
#[derive(Default)]
pub struct MaterialGroups {
    order: Vec<u32>,
    ranges: Vec<(usize, usize, u32)>,
    contiguous: bool,
    /// Per hit, its batch's number; per batch, (material group, first shape) and where its
    /// run of `order` starts.
    key: Vec<usize>,
    distinct: Vec<(u32, u32)>,
    starts: Vec<usize>,
    /// Per material group, its batch in the current call (`u32::MAX`: none).
    batch_of_group: Vec<u32>,
    /// Gathered inputs and outputs of one batch (when not contiguous).
    wo: Vec3s,
    wi: Vec3s,
    u: Vec2s,
    uc: Vec<f32>,
    f: Vec<Rgb>,
    pdf: Vec<f32>,
    samples: BsdfSamples,
}

/// The camera stage's queue: the sampler streams (pixel keys and sample indices), film
/// jitters and rays of a batch of samples of one or more pixels.
#[derive(Default)]
pub struct CameraQueue {
    pub key: Vec<u64>,
    pub index: Vec<u32>,
    pub ray: Rays,
    jitter: Vec2s,
}

impl CameraQueue {
    /// Empties the queue.
    pub fn clear(&mut self) {
        self.key.clear();
        self.index.clear();
        self.ray.clear();
    }

    /// Appends the camera rays of samples `first..first + count` of pixel (x, y): the
    /// sampler's camera dimension for all of them at once, then the camera's batched rays.
    /// Leaves `sampler` at the dimension after the camera's, as every sample is.
    pub fn push_pixel(
        &mut self,
        camera: &Camera,
        pixel: (u32, u32),
        first: u32,
        count: u32,
        inv_res: Vec2,
        sampler: &mut Sampler,
    ) {
        let start = self.index.len();
        sampler.start(pixel.0, pixel.1, first);
        self.index.extend(first..first + count);
        self.key
            .extend(std::iter::repeat_n(sampler.key(), count as usize));
        self.jitter.resize(count as usize);
        let (keys, idx) = (&self.key[start..], &self.index[start..]);
        sampler.next_2d_lanes(keys, idx, self.jitter.cols_mut());
        camera.rays_many(
            Vec2::new(pixel.0 as f32, pixel.1 as f32),
            self.jitter.cols(),
            inv_res,
            &mut self.ray,
        );
    }
}

/// Buffers of the wavefront, kept between pixels so that a tile allocates them once.
#[derive(Default)]
pub struct Wavefront {
    pub paths: Paths,
    /// The live paths; ray j of [`Paths::ray`] is path `active[j]`'s.
    pub active: Vec<u32>,
    /// The paths [`Wavefront::spawn`] keeps, swapped into `active`.
    pub next: Vec<u32>,
    /// The hit each path of `next` leaves from.
    next_hit: Vec<u32>,
    pub hits: HitQueue,
    pub escaped: EscapedQueue,
    pub scatter: ScatterQueue,
    pub lights: LightSampleQueue,
    pub shadow: ShadowQueue,
    pub bsdf_samples: BsdfSamples,
    /// Depth shared by all live paths.
    depth: u32,
}

impl Wavefront {
    /// Traces the paths of `rays` (samples `indices` of the pixels with keys `keys`;
    /// `sampler` at the dimension after the camera's) to `out`: the bounce loop over the
    /// stages.
    #[allow(clippy::too_many_arguments)] // the scalar `li`'s arguments, plus the batch's
    pub fn trace(
        &mut self,
        world: &World,
        rays: &Rays,
        keys: &[u64],
        indices: &[u32],
        sampler: &mut Sampler,
        max_depth: Option<u32>,
        rr_depth: u32,
        out: &mut [Rgb],
    ) {
        assert!(rays.len() == indices.len() && rays.len() == keys.len());
        assert_eq!(rays.len(), out.len());
        let max_depth = max_depth.unwrap_or(DEPTH_CAP).min(DEPTH_CAP);
        self.start(rays, keys, indices, max_depth);
        while !self.active.is_empty() {
            self.intersect(world);
            self.escaped(world);
            self.emission(world);
            let goes_on = self.depth + 1 < max_depth;
            if !goes_on || self.hits.it.is_empty() {
                break;
            }
            self.scatter_setup(world, sampler);
            self.light_samples(world);
            self.bsdf_eval(world);
            self.shadow_rays(world);
            self.bsdf_samples(world);
            self.spawn(sampler, rr_depth);
        }
        for (o, v) in out.iter_mut().zip(&self.paths.vars) {
            *o = v.l;
        }
    }

    fn start(&mut self, rays: &Rays, keys: &[u64], indices: &[u32], max_depth: u32) {
        let n = rays.len();
        let p = &mut self.paths;
        p.key.clear();
        p.key.extend_from_slice(keys);
        p.index.clear();
        p.index.extend_from_slice(indices);
        p.vars.clear();
        p.vars.resize(n, PathVars::START);
        self.depth = 0;
        self.active.clear();
        p.ray.clear();
        if max_depth > 0 {
            self.active.extend(0..n as u32);
            p.ray.copy_from(rays);
        }
    }

    /// Closest hits of the active paths (at depth 0 the camera's rays, a pixel's samples in
    /// a row, in packets of eight), split into hits (with their local geometry, computed in
    /// a second pass so that neither waits on the other's long dependency chains) and
    /// escaped paths with their directions.
    pub fn intersect(&mut self, world: &World) {
        debug_assert_eq!(
            self.paths.ray.len(),
            self.active.len(),
            "a ray per live path"
        );
        let h = &mut self.hits;
        h.closest.clear();
        let rays = &self.paths.ray;
        match self.depth {
            // The camera's rays: each pixel's samples are consecutive.
            0 => world.geometry.closest_many_coherent(rays, &mut h.closest),
            _ => world.geometry.closest_many(rays, &mut h.closest),
        }
        h.hits.clear();
        h.path.clear();
        let e = &mut self.escaped;
        e.path.clear();
        e.ray_index.clear();
        for (j, (&i, c)) in self.active.iter().zip(&h.closest).enumerate() {
            match *c {
                Some((t, prim)) => {
                    h.hits.push((j as u32, t, prim));
                    h.path.push(i);
                }
                None => {
                    e.path.push(i);
                    e.ray_index.push(j as u32);
                }
            }
        }
        e.dir.gather_from(rays.dirs(), &e.ray_index);
        world
            .geometry
            .interactions_many(&self.paths.ray, &h.hits, &mut h.it);
    }

    /// Escaped paths gather the infinite lights, each light's values in one batch.
    pub fn escaped(&mut self, world: &World) {
        let e = &mut self.escaped;
        if e.path.is_empty() {
            return;
        }
        let p = &mut self.paths;
        let sel_pdf = world.light_select_pdf();
        for &k in &world.infinite_lights {
            let light = &world.lights[k as usize];
            e.le_pdf.clear();
            e.le_pdf.resize(e.dir.len(), (Rgb::ZERO, 0.0));
            light.le_pdf_infinite_many(e.dir.cols(), &mut e.le_pdf);
            for (&i, &(le, pdf)) in e.path.iter().zip(&e.le_pdf) {
                if le.is_black() {
                    continue;
                }
                let v = &mut p.vars[i as usize];
                let w = if self.depth == 0 {
                    1.0
                } else {
                    power_heuristic(v.prev_pdf, sel_pdf * pdf)
                };
                v.l += v.beta * le * w;
            }
        }
    }

    /// Hits on emitters add their emission (MIS-weighted against light sampling after
    /// the first bounce).
    pub fn emission(&mut self, world: &World) {
        let sel_pdf = world.light_select_pdf();
        let p = &mut self.paths;
        let its = &self.hits.it;
        for (h, (&i, &shape)) in self.hits.path.iter().zip(its.shape()).enumerate() {
            let Some(k) = world.shapes[shape as usize].light else {
                continue;
            };
            let (i, it) = (i as usize, &its.get(h));
            let light = &world.lights[k as usize];
            let ray = self.hits.hits[h].0 as usize;
            let le = light.le_area(it, -p.ray.dirs().get(ray));
            if le.is_black() {
                continue;
            }
            let v = &mut p.vars[i];
            let w = if self.depth == 0 {
                1.0
            } else {
                power_heuristic(v.prev_pdf, sel_pdf * light.pdf_area(v.prev_p, it))
            };
            v.l += v.beta * le * w;
        }
    }

    /// Shading frames and outgoing directions of the scattering hits (a lane vector at a time in
    /// SIMD lanes: [`shading_lanes`]), the sampler dimensions of this bounce for all of them
    /// (light choice and point, BSDF lobe and direction), and the hits grouped by
    /// material.
    pub fn scatter_setup(&mut self, world: &World, sampler: &mut Sampler) {
        let (h, s, p) = (&self.hits, &mut self.scatter, &self.paths);
        let m = h.it.len();
        for v in [&mut s.frame_s, &mut s.frame_t, &mut s.wo] {
            v.resize(m);
        }
        let (ns, dpdu) = (h.it.ns(), h.it.dpdu());
        for first in (0..m).step_by(LANES) {
            let n = (m - first).min(LANES);
            // The hits' ray indices increase (`intersect` sorts the hits out in ray order),
            // so a chunk where every ray hit is one plain load per column.
            let rays: [usize; LANES] = simd::lanes(|k| h.hits[first + k.min(n - 1)].0 as usize);
            shading_lanes(
                ns.load(first),
                dpdu.load(first),
                p.ray.dirs().lanes_of(&rays[..n]),
                first,
                [&mut s.frame_s, &mut s.frame_t, &mut s.wo],
            );
        }
        s.streams_of(p, &h.path);
        s.light_uc.resize(m, 0.0);
        s.light_u.resize(m);
        s.bsdf_uc.resize(m, 0.0);
        s.bsdf_u.resize(m);
        let (keys, idx) = (&s.sample_key, &s.sample_index);
        sampler.next_1d_lanes(keys, idx, &mut s.light_uc);
        sampler.next_2d_lanes(keys, idx, s.light_u.cols_mut());
        sampler.next_1d_lanes(keys, idx, &mut s.bsdf_uc);
        sampler.next_2d_lanes(keys, idx, s.bsdf_u.cols_mut());
        s.groups.build(world, h.it.shape());
    }

    /// One light sample per scattering hit: the light chosen uniformly by the hit's
    /// light-choice value, the requests to each light sampled in one batch
    /// ([`Light::sample_li_many`]; when one light takes every request, as in scenes of one
    /// light, the queue itself is the batch).
    pub fn light_samples(&mut self, world: &World) {
        let (s, q) = (&self.scatter, &mut self.lights);
        let m = self.hits.it.len();
        q.samples.reset(m);
        let n_lights = world.lights.len();
        if n_lights == 0 {
            return;
        }
        // Requests grouped by light; when one light takes them all (as in scenes of one
        // light), the queue itself is its batch.
        let choice = |uc: f32| ((uc * n_lights as f32) as usize).min(n_lights - 1);
        let its = &self.hits.it;
        q.starts.resize(n_lights + 1, 0);
        q.order.resize(m, 0);
        let light_of = |h: usize| Some(choice(s.light_uc[h]));
        group_stable(m, light_of, &mut q.starts, &mut q.order);
        if let Some(k) = (0..n_lights).find(|&k| q.starts[k + 1] - q.starts[k] == m) {
            world.lights[k].sample_li_many(its.p(), s.light_u.cols(), &mut q.samples);
            return;
        }
        for k in 0..n_lights {
            let hits = &q.order[q.starts[k]..q.starts[k + 1]];
            if hits.is_empty() {
                continue;
            }
            q.p.gather_from(its.p(), hits);
            q.u.gather_from(s.light_u.cols(), hits);
            world.lights[k].sample_li_many(q.p.cols(), q.u.cols(), &mut q.batch);
            for (j, &h) in hits.iter().enumerate() {
                q.samples.copy_from(h as usize, &q.batch, j);
            }
        }
    }

    /// The BSDF's value and density at every light sample, one batched call per material
    /// (for hits without a sample, pdf 0, the direction is whatever the buffer held: their
    /// values are not used).
    pub fn bsdf_eval(&mut self, world: &World) {
        let (s, q) = (&mut self.scatter, &mut self.lights);
        let m = s.wo.len();
        let its = &self.hits.it;
        q.wi_local.resize(m);
        // Frames, normals and directions straight from their columns, a lane vector at a time.
        let (fs, ft) = (s.frame_s.cols(), s.frame_t.cols());
        for first in (0..m).step_by(LANES) {
            let n = its.ns().load(first);
            let wi = q.samples.wi.cols().load(first);
            let local = frame::to_local(fs.load(first), ft.load(first), n, wi);
            q.wi_local.cols_mut().store(first, local);
        }
        q.f.resize(m, Rgb::ZERO);
        q.bsdf_pdf.resize(m, 0.0);
        let (wo, wi) = (s.wo.cols(), q.wi_local.cols());
        s.groups.eval_pdf(world, wo, wi, &mut q.f, &mut q.bsdf_pdf);
    }

    /// Light samples the BSDF reflects are tested for occlusion together; the unoccluded
    /// ones add their MIS-weighted contribution. A light sample counts when its pdf is
    /// positive, its radiance and the reflected value are not black; these are kept by a
    /// branch-free compaction (whether a light sample lies above the surface is a coin
    /// flip a branch would mispredict).
    pub fn shadow_rays(&mut self, world: &World) {
        let (ls, q, sq) = (&self.lights.samples, &self.lights, &mut self.shadow);
        let m = q.wi_local.len();
        sq.hit.resize(m, 0);
        sq.f.resize(m, Rgb::ZERO);
        let mut kept = 0;
        for (h, ((&wi_z, &f), (&pdf, li))) in q
            .wi_local
            .cols()
            .z()
            .iter()
            .zip(&q.f)
            .zip(ls.pdf.iter().zip(&ls.li))
            .enumerate()
        {
            if !(pdf > 0.0) || li.is_black() {
                continue;
            }
            let f = f * wi_z.max(0.0);
            sq.hit[kept] = h as u32;
            sq.f[kept] = f;
            kept += !f.is_black() as usize;
        }
        sq.hit.truncate(kept);
        sq.f.truncate(kept);
        // Rays toward directions (infinite lights) in lanes, as `spawn_ray`; rays toward
        // points one by one. Cleared first, so that every ray starts with `Ray::new`'s
        // range, which the lane stores keep.
        let its = &self.hits.it;
        sq.ray.clear();
        sq.ray.resize(sq.hit.len());
        for (c, chunk) in sq.hit.chunks(LANES).enumerate() {
            let idx = lane_indices(chunk);
            let idx = &idx[..chunk.len()];
            if idx.iter().all(|&h| ls.at[h].is_none()) {
                let d = ls.wi.cols().lanes_of(idx);
                let (o, skip) = its.spawn_lanes(idx, d);
                sq.ray.store_lanes(LANES * c, o, d, skip);
                continue;
            }
            for (k, &h) in idx.iter().enumerate() {
                let ray = shadow_ray(&its.get(h), ls.wi.get(h), ls.at[h]);
                sq.ray.set(LANES * c + k, ray);
            }
        }
        sq.occluded.clear();
        world.geometry.occluded_many(&sq.ray, &mut sq.occluded);
        let sel_pdf = world.light_select_pdf();
        let p = &mut self.paths;
        for ((&h, &f), &occluded) in sq.hit.iter().zip(&sq.f).zip(&sq.occluded) {
            if occluded {
                continue;
            }
            let h = h as usize;
            let light_pdf = ls.pdf[h] * sel_pdf;
            let w = if ls.delta[h] {
                1.0
            } else {
                power_heuristic(light_pdf, q.bsdf_pdf[h])
            };
            let v = &mut p.vars[self.hits.path[h] as usize];
            v.l += v.beta * f * ls.li[h] * (w / light_pdf);
        }
    }

    /// BSDF samples of every scattering hit, one batched call per material.
    pub fn bsdf_samples(&mut self, world: &World) {
        let s = &mut self.scatter;
        self.bsdf_samples.reset(s.wo.len());
        s.groups.sample(
            world,
            s.wo.cols(),
            s.bsdf_u.cols(),
            &s.bsdf_uc,
            self.bsdf_samples.cols_mut(),
        );
    }

    /// Paths whose BSDF sample carries throughput go on along it; then Russian roulette
    /// (one sampler dimension for all, since they share their depth); then the rays of the
    /// paths that go on, in their order, become [`Paths::ray`] (none is made for a path
    /// that roulette ends).
    pub fn spawn(&mut self, sampler: &mut Sampler, rr_depth: u32) {
        let p = &mut self.paths;
        self.next.clear();
        self.next_hit.clear();
        let its = &self.hits.it;
        for (h, (bs, &i)) in self.bsdf_samples.iter().zip(&self.hits.path).enumerate() {
            let Some(bs) = bs else {
                continue;
            };
            let v = &mut p.vars[i as usize];
            v.beta *= bs.weight;
            if v.beta.is_black() || !v.beta.is_finite() {
                continue;
            }
            v.prev_pdf = bs.pdf;
            v.prev_p = its.p().get(h);
            self.next.push(i);
            self.next_hit.push(h as u32);
        }
        self.depth += 1;
        if self.depth >= rr_depth && !self.next.is_empty() {
            self.russian_roulette(sampler);
        }
        // The rays in lanes: the sampled directions to world space in their hits' shading
        // frames, then `spawn_ray`'s origins and skipped primitives.
        let (its, s, rays) = (&self.hits.it, &self.scatter, &mut self.paths.ray);
        let wi = self.bsdf_samples.wi();
        rays.clear();
        rays.resize(self.next_hit.len());
        for (c, chunk) in self.next_hit.chunks(LANES).enumerate() {
            let idx = lane_indices(chunk);
            let idx = &idx[..chunk.len()];
            let (fs, ft) = (
                s.frame_s.cols().lanes_of(idx),
                s.frame_t.cols().lanes_of(idx),
            );
            let d = frame::to_world(fs, ft, its.ns().lanes_of(idx), wi.lanes_of(idx));
            let (o, skip) = its.spawn_lanes(idx, d);
            rays.store_lanes(LANES * c, o, d, skip);
        }
        std::mem::swap(&mut self.active, &mut self.next);
    }

    /// Russian roulette on the paths of `next` (and their hits in `next_hit`, filtered
    /// with them): one sampler dimension drawn for their streams in order, and each goes on
    /// with probability its throughput's largest component (at most 0.95), its throughput
    /// divided by it.
    fn russian_roulette(&mut self, sampler: &mut Sampler) {
        let (p, s) = (&mut self.paths, &mut self.scatter);
        s.streams_of(p, &self.next);
        let n = self.next.len();
        s.light_uc.resize(n, 0.0);
        sampler.next_1d_lanes(&s.sample_key, &s.sample_index, &mut s.light_uc[..n]);
        let mut kept = 0;
        for j in 0..n {
            let i = self.next[j];
            let v = &mut p.vars[i as usize];
            let q = v.beta.max_component().min(0.95);
            if s.light_uc[j] >= q {
                continue;
            }
            v.beta = v.beta / q;
            self.next[kept] = i;
            self.next_hit[kept] = self.next_hit[j];
            kept += 1;
        }
        self.next.truncate(kept);
        self.next_hit.truncate(kept);
    }
}

impl ScatterQueue {
    /// The sampler streams (pixel keys and sample indices) of the paths `paths`.
    fn streams_of(&mut self, p: &Paths, paths: &[u32]) {
        self.sample_key.clear();
        self.sample_key
            .extend(paths.iter().map(|&i| p.key[i as usize]));
        self.sample_index.clear();
        self.sample_index
            .extend(paths.iter().map(|&i| p.index[i as usize]));
    }
}

impl MaterialGroups {
    /// Groups the hits by material, given the shapes they hit (shapes sharing a material
    /// share its batch): each hit's material group
    /// ([`crate::scene::ShapeInfo::material_group`]) given a batch in order of first
    /// appearance, then a stable counting sort. When the hits already come grouped (scenes
    /// of one material), the batches read the queues in place.
    fn build(&mut self, world: &World, shapes: &[u32]) {
        self.key.clear();
        // The batch of each material group seen in the last call back to none.
        for &(group, _) in &self.distinct {
            self.batch_of_group[group as usize] = u32::MAX;
        }
        self.distinct.clear();
        for &shape in shapes {
            let group = world.shapes[shape as usize].material_group as usize;
            if group >= self.batch_of_group.len() {
                self.batch_of_group.resize(group + 1, u32::MAX);
            }
            let mut g = self.batch_of_group[group] as usize;
            if g == u32::MAX as usize {
                g = self.distinct.len();
                self.batch_of_group[group] = g as u32;
                self.distinct.push((group as u32, shape));
            }
            self.key.push(g);
        }
        self.order.resize(shapes.len(), 0);
        self.starts.resize(self.distinct.len() + 1, 0);
        let key = &self.key;
        group_stable(
            shapes.len(),
            |h| Some(key[h]),
            &mut self.starts,
            &mut self.order,
        );
        self.ranges.clear();
        for (g, &(_, shape)) in self.distinct.iter().enumerate() {
            self.ranges
                .push((self.starts[g], self.starts[g + 1], shape));
        }
        self.contiguous = self.order.iter().enumerate().all(|(j, &h)| j == h as usize);
    }

    fn material(world: &World, shape: u32) -> &dyn Bsdf {
        world.shapes[shape as usize].material.as_ref()
    }

    /// [`Bsdf::eval_pdf_many`] of every hit, one call per material.
    fn eval_pdf(
        &mut self,
        world: &World,
        wo: Vec3Cols,
        wi: Vec3Cols,
        f: &mut [Rgb],
        pdf: &mut [f32],
    ) {
        for &(a, b, shape) in &self.ranges {
            let bsdf = Self::material(world, shape);
            if self.contiguous {
                let (o, i) = (wo.slice(a..b), wi.slice(a..b));
                bsdf.eval_pdf_many(o, i, &mut f[a..b], &mut pdf[a..b]);
                continue;
            }
            let hits = &self.order[a..b];
            self.wo.gather_from(wo, hits);
            self.wi.gather_from(wi, hits);
            self.f.resize(hits.len(), Rgb::ZERO);
            self.pdf.resize(hits.len(), 0.0);
            let (o, i) = (self.wo.cols(), self.wi.cols());
            bsdf.eval_pdf_many(o, i, &mut self.f, &mut self.pdf);
            for (j, &h) in hits.iter().enumerate() {
                f[h as usize] = self.f[j];
                pdf[h as usize] = self.pdf[j];
            }
        }
    }

    /// [`Bsdf::sample_many`] of every hit, one call per material.
    fn sample(
        &mut self,
        world: &World,
        wo: Vec3Cols,
        u: Vec2Cols,
        uc: &[f32],
        mut out: BsdfSamplesMut,
    ) {
        for &(a, b, shape) in &self.ranges {
            let bsdf = Self::material(world, shape);
            if self.contiguous {
                bsdf.sample_many(wo.slice(a..b), u.slice(a..b), &uc[a..b], out.slice(a..b));
                continue;
            }
            let hits = &self.order[a..b];
            self.wo.gather_from(wo, hits);
            self.u.gather_from(u, hits);
            gather(&mut self.uc, uc, hits);
            self.samples.reset(hits.len());
            bsdf.sample_many(
                self.wo.cols(),
                self.u.cols(),
                &self.uc,
                self.samples.cols_mut(),
            );
            for (j, &h) in hits.iter().enumerate() {
                out.set(h as usize, self.samples.get(j));
            }
        }
    }
}

/// The indices of a chunk of at most [`LANES`] hits, as `usize`s (zero past its end).
fn lane_indices(chunk: &[u32]) -> [usize; LANES] {
    let mut idx = [0; LANES];
    for (i, &h) in idx.iter_mut().zip(chunk) {
        *i = h as usize;
    }
    idx
}

/// `dst[j] = src[idx[j]]`.
fn gather<T: Copy>(dst: &mut Vec<T>, src: &[T], idx: &[u32]) {
    dst.clear();
    dst.extend(idx.iter().map(|&i| src[i as usize]));
}
