//! The render loop: the image is cut into 16 x 16 tiles rendered in parallel by rayon;
//! every pixel sample draws its numbers from the per-pixel seeded sampler, and every
//! pixel is accumulated in a fixed order, so the image is bit-identical whatever the
//! number of threads. Non-finite samples are dropped (and counted) instead of being
//! written into the image. Progress is reported through a callback ([`Progress`]) as
//! tiles finish: the CLI draws its bar from it, the Python package its tqdm bar.

use crate::Rgb;
use crate::error::{Error, Result};
use crate::film::Image;
use crate::integrators::wavefront::{CameraQueue, Wavefront};
use crate::limits::MAX_THREADS;
use crate::partial::PartialRender;
use crate::sampler::Sampler;
use crate::scene::Scene;
use glam::Vec2;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use wide::f64x4;

const TILE: u32 = 16;
/// Samples traced together by the wavefront integrator: the samples of as many pixels as
/// fit (a pixel of more samples goes in pieces of this size). Larger wavefronts fill the
/// SIMD lanes of the batched material and light calls better, above all in scenes of
/// several materials and at the later bounces, where few paths remain.
const WAVEFRONT: u32 = 512;

/// A render's progress report: called with (pixels done, pixels of the film) each time a
/// tile finishes, from the render's worker threads but one call at a time, with `done`
/// increasing and the last call at `done == total`. Called per tile, never per sample, so
/// that it costs nothing measurable; it must return quickly (it holds up one worker).
#[derive(Clone)]
pub struct Progress(Arc<dyn Fn(u64, u64) + Send + Sync>);

impl Progress {
    pub fn new(f: impl Fn(u64, u64) + Send + Sync + 'static) -> Self {
        Progress(Arc::new(f))
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress(..)")
    }
}

/// How to run a render.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Worker threads; `None` uses rayon's global pool (all cores).
    pub threads: Option<usize>,
    /// Told of the pixels done as tiles finish (a progress bar).
    pub progress: Option<Progress>,
    /// Set to true (e.g. by a Ctrl-C handler) to stop the render early; it then returns
    /// [`Error::Other`] ("interrupted") and nothing is written.
    pub cancel: Option<Arc<AtomicBool>>,
}

/// What a render did.
#[derive(Clone, Debug)]
pub struct RenderStats {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seconds: f64,
    /// Camera paths traced (width x height x spp).
    pub samples: u64,
    /// Samples whose radiance was NaN or infinite, dropped from the image.
    pub nonfinite_dropped: u64,
    pub threads: usize,
    /// The scene's geometry: primitives, and bytes of the BVH and of the primitives and
    /// mesh data.
    pub primitives: usize,
    pub bvh_bytes: usize,
    pub primitive_bytes: usize,
    /// The BVH's surface area heuristic cost (its quality, free of timing noise:
    /// [`crate::geometry::bvh8::Bvh8::sah_cost`]).
    pub bvh_sah_cost: f64,
    /// Where the scene's loading time went (reading meshes, building the BVH).
    pub load: crate::scene::LoadTimes,
}

/// The share of a render's samples that may be non-finite (and dropped) before its image
/// counts as biased: [`RenderStats::check_dropped`] fails above it.
pub const MAX_DROPPED_SHARE: f64 = 1e-4;

impl RenderStats {
    /// Fails ([`Error::Biased`]) when more than [`MAX_DROPPED_SHARE`] of the samples were
    /// NaN or infinite: the image then lacks their light and is biased, however long the
    /// render. The causes are values beyond f32: an emitter's radiance or scale, or a
    /// material's value or sample weight.
    pub fn check_dropped(&self, scene: &str) -> Result<()> {
        let share = self.nonfinite_dropped as f64 / self.samples.max(1) as f64;
        if share > MAX_DROPPED_SHARE {
            return Err(Error::Biased(format!(
                "{scene}: {} of {} samples ({:.3} %) were NaN or infinite and were dropped, so the image is biased; expected at most {} % (look for radiance, scales or material values that overflow f32)",
                self.nonfinite_dropped,
                self.samples,
                share * 100.0,
                MAX_DROPPED_SHARE * 100.0
            )));
        }
        Ok(())
    }

    pub fn msamples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-9) / 1e6
    }

    /// The one-line summary printed after a render.
    pub fn summary(&self) -> String {
        format!(
            "{}x{} at {} spp in {:.2} s: {:.2} Msamples/s on {} threads, {} non-finite samples dropped",
            self.width,
            self.height,
            self.spp,
            self.seconds,
            self.msamples_per_second(),
            self.threads,
            self.nonfinite_dropped
        )
    }

    /// Where the scene's loading time went, in one line.
    pub fn load_summary(&self) -> String {
        format!(
            "scene loaded in {:.2} s: meshes read in {:.2} s, BVH of {} primitives built in {:.2} s ({:.1} MB, primitives and meshes {:.1} MB)",
            self.load.total_seconds,
            self.load.mesh_read_seconds,
            self.primitives,
            self.load.bvh_build_seconds,
            self.bvh_bytes as f64 / 1e6,
            self.primitive_bytes as f64 / 1e6
        )
    }

    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "width": self.width,
            "height": self.height,
            "spp": self.spp,
            "seconds": self.seconds,
            "samples": self.samples,
            "msamples_per_second": self.msamples_per_second(),
            "nonfinite_dropped": self.nonfinite_dropped,
            "threads": self.threads,
            "simd_lanes": lobe_materials::simd::LANES,
            "geometry": {
                "primitives": self.primitives,
                "bvh_bytes": self.bvh_bytes,
                "bvh_sah_cost": self.bvh_sah_cost,
                "primitive_bytes": self.primitive_bytes,
                "bvh_build_seconds": self.load.bvh_build_seconds,
                "mesh_read_seconds": self.load.mesh_read_seconds,
            },
            "load_seconds": self.load.total_seconds,
        })
    }
}

struct TileResult {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    /// The tile's pixels in row-major order.
    sums: Vec<PixelSums>,
    dropped: u64,
}

/// A pixel's running sums over its finite samples, per channel (r, g, b, unused) in one
/// f64x4 register each: the same sums as channel by channel, in sample order.
#[derive(Clone, Copy)]
struct PixelSums {
    sum: f64x4,
    sum2: f64x4,
    n: u32,
}

impl PixelSums {
    const ZERO: Self = Self {
        sum: f64x4::ZERO,
        sum2: f64x4::ZERO,
        n: 0,
    };

    /// Adds `samples` in order; non-finite ones are counted in `dropped` instead.
    fn add(&mut self, samples: &[Rgb], dropped: &mut u64) {
        for &l in samples {
            if !l.is_finite() {
                *dropped += 1;
                continue;
            }
            self.n += 1;
            let c = f64x4::new([l.r as f64, l.g as f64, l.b as f64, 0.0]);
            self.sum += c;
            self.sum2 += c * c;
        }
    }

    /// The sums of r, g, b and of their squares.
    fn channels(&self) -> ([f64; 3], [f64; 3]) {
        let (s, s2) = (self.sum.to_array(), self.sum2.to_array());
        ([s[0], s[1], s[2]], [s2[0], s2[1], s2[2]])
    }

    /// The mean and the variance of the mean.
    fn mean_and_variance(&self) -> (Rgb, Rgb) {
        let (sum, sum2) = self.channels();
        crate::partial::mean_and_variance(sum, sum2, self.n)
    }
}

/// Renders the samples `samples` of each pixel of one tile; returns None as soon as
/// `cancel` is set (checked per wavefront, so that a high-spp render stops promptly). The
/// tile's pixels, in row-major order, are cut into pieces of at most [`WAVEFRONT`] samples, and consecutive pieces are traced
/// together up to that many samples: every sample's numbers depend on its pixel and
/// index alone, and each pixel sums its samples in order, so the image does not depend
/// on how the pieces are grouped.
fn render_tile(
    scene: &Scene,
    (x0, y0): (u32, u32),
    samples: Range<u32>,
    cancel: Option<&AtomicBool>,
) -> Option<TileResult> {
    let w = TILE.min(scene.settings.width - x0);
    let h = TILE.min(scene.settings.height - y0);
    let spp = scene.settings.spp;
    let mut sampler = Sampler::with_scramble(scene.settings.seed, spp, scene.settings.scramble);
    let inv = Vec2::new(
        1.0 / scene.settings.width as f32,
        1.0 / scene.settings.height as f32,
    );
    let pixels: Vec<(u32, u32)> = (y0..y0 + h)
        .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
        .collect();
    let mut sums = vec![PixelSums::ZERO; pixels.len()];
    let mut dropped = 0u64;
    // (pixel, first sample, samples) of each piece, in order.
    let (begin, end) = (samples.start, samples.end.min(spp));
    let piece = (end - begin.min(end)).clamp(1, WAVEFRONT);
    let mut pieces = (0..pixels.len())
        .flat_map(|p| {
            (begin..end)
                .step_by(piece as usize)
                .map(move |first| (p, first))
        })
        .map(|(p, first)| (p, first, (end - first).min(piece)))
        .peekable();
    let mut radiance = Vec::new();
    let mut owners: Vec<(usize, usize)> = Vec::new();
    let (mut camera, mut wf) = (CameraQueue::default(), Wavefront::default());
    while pieces.peek().is_some() {
        if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return None;
        }
        camera.clear();
        owners.clear();
        while let Some(&(p, first, count)) = pieces.peek() {
            if !owners.is_empty() && camera.index.len() + count as usize > WAVEFRONT as usize {
                break;
            }
            pieces.next();
            // `sampler` is left at the dimension after the camera's, as every sample is.
            camera.push_pixel(&scene.camera, pixels[p], first, count, inv, &mut sampler);
            owners.push((p, count as usize));
        }
        radiance.clear();
        radiance.resize(camera.index.len(), Rgb::ZERO);
        let (rays, keys, indices) = (&camera.ray, &camera.key, &camera.index);
        scene.settings.integrator.li_many(
            &scene.world,
            rays,
            keys,
            indices,
            &mut sampler,
            &mut radiance,
            &mut wf,
        );
        let mut rest = radiance.as_slice();
        for &(p, count) in &owners {
            let (mine, others) = rest.split_at(count);
            sums[p].add(mine, &mut dropped);
            rest = others;
        }
    }
    Some(TileResult {
        x0,
        y0,
        w,
        h,
        sums,
        dropped,
    })
}

/// Renders the scene. Refuses a film above [`MAX_FILM_PIXELS`] or more than
/// [`MAX_THREADS`] threads, allocates the film fallibly (an error, not an abort, under a
/// memory limit) and starts no more threads than there are tiles.
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<(Image, RenderStats)> {
    let mut img = Image::try_new(scene.settings.width, scene.settings.height)?;
    img.variance_dof = (scene.settings.spp.max(2) - 1) as f64;
    // Each finished tile goes straight into the film, so memory is the film plus a tile
    // per thread; every pixel's value is computed by one tile alone, so the order in
    // which tiles finish changes nothing.
    let film = Mutex::new(&mut img);
    let width = scene.settings.width;
    let run = run_tiles(scene, 0..scene.settings.spp, opts, &|t: &TileResult| {
        let mut img = film.lock().unwrap_or_else(|e| e.into_inner());
        for j in 0..t.h {
            for i in 0..t.w {
                let dst = ((t.y0 + j) * width + t.x0 + i) as usize;
                let (m, v) = t.sums[(j * t.w + i) as usize].mean_and_variance();
                img.pixels[dst] = m;
                img.variance[dst] = v;
            }
        }
    })?;
    Ok((img, run.stats(scene, scene.settings.spp)))
}

/// Renders the samples `first..last` of every pixel (of the scene's `spp`), as per-pixel
/// sums that add up with other ranges' to the whole render ([`PartialRender`]).
pub fn render_samples(
    scene: &Scene,
    (first, last): (u32, u32),
    opts: &RenderOptions,
) -> Result<(PartialRender, RenderStats)> {
    if !(first < last && last <= scene.settings.spp) {
        return Err(Error::Other(format!(
            "samples {first}:{last}: expected a range FIRST:LAST with 0 <= FIRST < LAST <= {} (the scene's samples per pixel)",
            scene.settings.spp
        )));
    }
    let size = (scene.settings.width, scene.settings.height);
    let mut part =
        PartialRender::try_new(size, scene.settings.spp, (first, last), scene.render_key())?;
    let sums = Mutex::new(&mut part);
    let width = scene.settings.width;
    let run = run_tiles(scene, first..last, opts, &|t: &TileResult| {
        let mut p = sums.lock().unwrap_or_else(|e| e.into_inner());
        for j in 0..t.h {
            for i in 0..t.w {
                let dst = ((t.y0 + j) * width + t.x0 + i) as usize;
                let px = &t.sums[(j * t.w + i) as usize];
                (p.sum[dst], p.sum2[dst]) = px.channels();
                p.count[dst] = px.n;
            }
        }
    })?;
    part.dropped = run.dropped;
    Ok((part, run.stats(scene, last - first)))
}

/// What a pass over the tiles did.
struct TileRun {
    seconds: f64,
    threads: usize,
    dropped: u64,
}

impl TileRun {
    fn stats(&self, scene: &Scene, spp: u32) -> RenderStats {
        RenderStats {
            width: scene.settings.width,
            height: scene.settings.height,
            spp,
            seconds: self.seconds,
            samples: scene.settings.width as u64 * scene.settings.height as u64 * spp as u64,
            nonfinite_dropped: self.dropped,
            threads: self.threads,
            primitives: scene.world.geometry.prims.len(),
            bvh_bytes: scene.world.geometry.bvh_memory_bytes(),
            bvh_sah_cost: scene.world.geometry.bvh_sah_cost(),
            primitive_bytes: scene.world.geometry.primitive_memory_bytes(),
            load: scene.load_times,
        }
    }
}

/// Renders the samples `samples` of every tile in parallel, handing each finished tile to
/// `store` and reporting progress; an error when cancelled.
fn run_tiles(
    scene: &Scene,
    samples: Range<u32>,
    opts: &RenderOptions,
    store: &(dyn Fn(&TileResult) + Sync),
) -> Result<TileRun> {
    let tiles: Vec<(u32, u32)> = (0..scene.settings.height.div_ceil(TILE))
        .flat_map(|ty| {
            (0..scene.settings.width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE))
        })
        .collect();
    let pool = match opts.threads {
        Some(n) if n > MAX_THREADS => {
            return Err(Error::Other(format!(
                "{n} render threads requested; expected 1 to {MAX_THREADS} (more threads than cores only slow a render down)"
            )));
        }
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n.clamp(1, tiles.len().max(1)))
                .build()
                .map_err(|e| Error::Other(format!("cannot start {n} render threads: {e}")))?,
        ),
        None => None,
    };
    let threads = pool
        .as_ref()
        .map_or_else(rayon::current_num_threads, |p| p.current_num_threads());
    let total = scene.settings.width as u64 * scene.settings.height as u64;
    // Pixels done; its lock also keeps the progress calls one at a time and in order.
    let done = Mutex::new(0u64);
    let cancelled = AtomicBool::new(false);
    let dropped = AtomicU64::new(0);
    let start = Instant::now();
    let run = || {
        tiles.par_iter().for_each(|&tile| {
            let stop = || {
                opts.cancel
                    .as_ref()
                    .is_some_and(|c| c.load(Ordering::Relaxed))
            };
            if stop() || cancelled.load(Ordering::Relaxed) {
                cancelled.store(true, Ordering::Relaxed);
                return;
            }
            let Some(t) = render_tile(scene, tile, samples.clone(), opts.cancel.as_deref()) else {
                cancelled.store(true, Ordering::Relaxed);
                return;
            };
            dropped.fetch_add(t.dropped, Ordering::Relaxed);
            store(&t);
            if let Some(p) = &opts.progress {
                let mut d = done.lock().unwrap_or_else(|e| e.into_inner());
                *d += (t.w * t.h) as u64;
                (p.0)(*d, total);
            }
        })
    };
    match &pool {
        Some(p) => p.install(run),
        None => run(),
    };
    let seconds = start.elapsed().as_secs_f64();
    if cancelled.load(Ordering::Relaxed) {
        return Err(Error::Other(
            "render interrupted; nothing was written".into(),
        ));
    }
    Ok(TileRun {
        seconds,
        threads,
        dropped: dropped.into_inner(),
    })
}
