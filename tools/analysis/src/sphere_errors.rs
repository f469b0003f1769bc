//! Image errors of the representations of one material (its measured data, its fits, its
//! microfacet estimate) on a sphere under an environment map, with their 95 % intervals and
//! the noise floor: the comparison of Ngan, Durand and Matusik 2005 (Figures 3 and 6,
//! section 4.3) made so that its numbers measure the models rather than Monte Carlo noise.
//!
//! A sphere lit by a distant map alone is a per-pixel integral with no occlusion,
//!
//!   I(pixel) = int_pixel int L(wi) f(wi, wo) max(0, n.wi) dwi dx,
//!
//! so every representation's image is estimated from the *same* samples (common random
//! numbers): per sample a film position in the pixel (box filter, the renderer's) and one
//! direction, drawn from one of three strategies: the map's importance sampling (half the
//! samples), the measured data's BRDF sampling (a quarter), and Phong-like cones cos^e
//! around the mirror direction (a quarter, e = 8 to 4096, so that a fit sharper than the
//! data is resolved too). Each sample is weighted by Veach's balance heuristic,
//! L cos / sum_j n_j p_j (the multi-sample estimator, unbiased for any BRDF), so a fit's
//! image minus the data's carries only the noise of `f_fit - f_data`: small where the fit
//! is close, and one pass serves every model.
//!
//! The samples of a pixel fall into `B` independent batches (point sets shifted at random
//! per pixel and batch, Cranley-Patterson). Per pixel and channel, with batch estimates
//! `d_b` of the difference and their mean `m` and sample variance `s^2`, `m^2 - s^2 / B` is
//! unbiased for the squared difference of the converged images, so the mean square error
//! carries no noise bias; its 95 % interval is the delete-one jackknife over batches with
//! Student's t (B - 1 degrees of freedom), taken through the square root to the RMSE. The
//! noise floor is the RMS standard error of the difference image, `sqrt(mean s^2 / B)`:
//! what noise alone adds to an error measured without the correction, and the size of the
//! noise left in a difference image or FLIP map. The sample count grows (a pilot pass, then
//! the count the pilot's noise calls for) until the noise floor is under a tenth of the
//! smallest fit error and every interval narrower than a fifth of its error, up to a cap.
//! Errors under [`ErrorSettings::negligible`] of the image's RMS are below what a display
//! shows and are exempt from these targets.

use lobe_materials::frame::Frame;
use lobe_materials::sampling::mirror_cones;
use lobe_materials::sampling::random::{hash, unit};
use lobe_materials::{Bsdf, Rgb};
use lobe_renderer::camera::Camera;
use lobe_renderer::compare::metrics;
use lobe_renderer::film::Image;
use lobe_renderer::geometry::sphere::Sphere;
use lobe_renderer::lights::envmap::EnvMap;
use rayon::prelude::*;

/// A sphere seen by a camera under an environment map: what the images show.
pub struct Stage<'a> {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub sphere: Sphere,
    pub env: &'a EnvMap,
}

/// Where the camera of [`Stage::sphere`] stands (looking at the origin, +y up) and its
/// field of view in degrees: a unit sphere fills about 57 % of the square film.
pub const CAMERA_ORIGIN: [f32; 3] = [0.0, 0.0, 4.5];
pub const FOV_DEGREES: f32 = 30.0;

impl<'a> Stage<'a> {
    /// The unit sphere at the origin on a `size` x `size` film, seen from
    /// [`CAMERA_ORIGIN`] with [`FOV_DEGREES`] (the scene `lobe study` and `lobe figure
    /// spheres` render), lit by `env`.
    pub fn sphere(env: &'a EnvMap, size: u32) -> Self {
        let to_world = lobe_renderer::camera::look_at(
            glam::Vec3::from(CAMERA_ORIGIN),
            glam::Vec3::ZERO,
            glam::Vec3::Y,
        )
        .unwrap_or(glam::Mat4::IDENTITY);
        Self {
            camera: Camera::perspective(to_world, FOV_DEGREES, size, size, 0.01),
            width: size,
            height: size,
            sphere: Sphere {
                center: glam::Vec3::ZERO,
                radius: 1.0,
            },
            env,
        }
    }

    /// The same stage as a scene description (for the path tracer), at `spp`.
    pub fn scene_json(&self, env_file: &str, spp: u32) -> serde_json::Value {
        serde_json::json!({
            "camera": {"type": "perspective", "fov": FOV_DEGREES, "origin": CAMERA_ORIGIN,
                       "target": [0, 0, 0], "up": [0, 1, 0]},
            "film": {"width": self.width, "height": self.height},
            "sampler": {"spp": spp, "seed": 0},
            "integrator": {"type": "path", "max_depth": 3},
            "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}],
            "lights": [{"type": "envmap", "file": env_file}]
        })
    }
}

/// How hard the estimate works.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorSettings {
    /// Independent batches per pixel (the jackknife's groups).
    pub batches: usize,
    /// Samples per pixel (all batches) of the pilot pass.
    pub pilot_spp: usize,
    /// The most samples per pixel the estimate may take.
    pub max_spp: usize,
    /// The noise floor's target, as a share of the smallest fit error.
    pub noise_ratio: f64,
    /// The interval width's target, as a share of its error.
    pub interval_ratio: f64,
    /// Errors under this share of the data image's RMS are negligible (no display shows
    /// them) and exempt from the targets.
    pub negligible: f64,
    /// Seeds every random number (the images are the same for any thread count).
    pub seed: u64,
}

impl Default for ErrorSettings {
    fn default() -> Self {
        Self {
            batches: 16,
            pilot_spp: 64,
            max_spp: 512,
            noise_ratio: 0.1,
            interval_ratio: 0.2,
            negligible: 1e-3,
            seed: 0,
        }
    }
}

/// The error of one representation against the measured data's image.
#[derive(Clone, Debug, PartialEq)]
pub struct RepError {
    /// RMSE over every pixel and channel, without the noise bias. For the data itself:
    /// the RMS standard error of its image (its distance from its own converged image).
    pub rmse: f64,
    /// Its 95 % interval.
    pub ci95: [f64; 2],
    /// RMS standard error of the difference image (for the data: of its image).
    pub noise: f64,
    /// Mean FLIP against the data's image at the common exposure. For the data: FLIP
    /// between the images of its two halves of batches (noise at half the samples).
    pub flip: f64,
    /// Under [`ErrorSettings::negligible`] of the image's RMS.
    pub negligible: bool,
}

impl RepError {
    /// The interval's width relative to the error.
    pub fn relative_width(&self) -> f64 {
        (self.ci95[1] - self.ci95[0]) / self.rmse.max(1e-300)
    }

    /// Whether this error's interval lies wholly below `other`'s.
    pub fn separated_below(&self, other: &RepError) -> bool {
        self.ci95[1] < other.ci95[0]
    }
}

/// The images and errors of every representation (index 0: the measured data).
#[derive(Clone, Debug)]
pub struct SphereErrors {
    pub images: Vec<Image>,
    pub errors: Vec<RepError>,
    /// FLIP error map of each representation against the data's image (index 0: the two
    /// halves of the data's batches).
    pub flip_maps: Vec<Vec<f32>>,
    /// The largest noise of the fits' difference images.
    pub noise_floor: f64,
    /// Samples per pixel of the reported pass, in how many batches, and passes made.
    pub spp: usize,
    pub batches: usize,
    pub passes: usize,
    /// The exposure (stops) of pictures and FLIP: under 1 % of the data image's pixels
    /// clip.
    pub exposure: f32,
    /// Whether the noise and interval targets hold on the non-negligible fits.
    pub noise_target_met: bool,
    pub interval_target_met: bool,
}

/// Radical inverse of `k` in base `b`.
fn radical_inverse(mut k: u64, b: u64) -> f64 {
    let (mut inv, mut f) = (0.0, 1.0 / b as f64);
    while k > 0 {
        inv += (k % b) as f64 * f;
        k /= b;
        f /= b as f64;
    }
    inv
}

/// Point `k` of a pixel's batch: 5 coordinates (film x, y; direction u, v; component),
/// a low-discrepancy set shifted modulo 1 by `shift`.
fn point(k: usize, n: usize, shift: &[f64; 5]) -> [f64; 5] {
    let base = [
        (k as f64 + 0.5) / n as f64,
        radical_inverse(k as u64, 2),
        radical_inverse(k as u64, 3),
        radical_inverse(k as u64, 5),
        radical_inverse(k as u64, 7),
    ];
    std::array::from_fn(|i| (base[i] + shift[i]).fract())
}

/// The samples of one pixel (all batches) that hit the sphere, as the batched
/// evaluations take them, and the background each batch sees where a sample misses.
#[derive(Default)]
struct PixelSamples {
    batch: Vec<usize>,
    wo: Vec<glam::Vec3>,
    wi: Vec<glam::Vec3>,
    radiance: Vec<[f64; 3]>,
    /// n_map p_map + n_cone p_cone of each sample (the data's term is added once its
    /// density is evaluated).
    density: Vec<f64>,
    background: Vec<[f64; 3]>,
}

/// A sample's direction before its densities: local (wo, wi) and the world direction.
struct Drawn {
    wo: glam::Vec3,
    wi: glam::Vec3,
    world: glam::Vec3,
    mirror: glam::DVec3,
}

impl Stage<'_> {
    /// The batch estimates (`[rep * batches + batch]`, RGB) of pixel (x, y) for every
    /// representation (`reps[0]` the data, whose sampling is one strategy), `per_batch`
    /// samples in each of `batches`: the samples are drawn first, then each
    /// representation evaluates all of them in one batched call.
    fn pixel(
        &self,
        reps: &[&dyn Bsdf],
        (x, y): (u32, u32),
        (per_batch, batches): (usize, usize),
        seed: u64,
    ) -> Vec<[f64; 3]> {
        let set = self.draw(reps[0], (x, y), (per_batch, batches), seed);
        let n = set.wi.len();
        let mut values = vec![[0.0f64; 3]; reps.len() * batches];
        for row in values.chunks_mut(batches) {
            row.copy_from_slice(&set.background);
        }
        let (mut f, mut pdf) = (vec![Rgb::splat(0.0); n], vec![0.0f32; n]);
        reps[0].eval_pdf_many(&set.wo, &set.wi, &mut f, &mut pdf);
        let n_data = (per_batch / 4) as f64;
        let weight: Vec<f64> = (0..n)
            .map(|k| {
                let density = set.density[k] + n_data * pdf[k] as f64;
                match density > 0.0 {
                    true => set.wi[k].z as f64 / density,
                    false => 0.0,
                }
            })
            .collect();
        for (r, rep) in reps.iter().enumerate() {
            if r > 0 {
                rep.eval_pdf_many(&set.wo, &set.wi, &mut f, &mut pdf);
            }
            for k in 0..n {
                let fk = f[k].to_array();
                let v: [f64; 3] =
                    std::array::from_fn(|c| fk[c] as f64 * set.radiance[k][c] * weight[k]);
                if v.iter().all(|x| x.is_finite()) {
                    add(&mut values[r * batches + set.batch[k]], v, 1.0);
                }
            }
        }
        values
    }

    /// The samples of pixel (x, y).
    fn draw(
        &self,
        data: &dyn Bsdf,
        (x, y): (u32, u32),
        (per_batch, batches): (usize, usize),
        seed: u64,
    ) -> PixelSamples {
        let mut set = PixelSamples {
            background: vec![[0.0; 3]; batches],
            ..Default::default()
        };
        let pixel_id = y as u64 * self.width as u64 + x as u64;
        let counts = [per_batch / 2, per_batch / 4, per_batch / 4];
        for b in 0..batches {
            let key = hash(hash(seed, pixel_id), b as u64);
            let shift: [f64; 5] = std::array::from_fn(|i| unit(hash(hash(key, i as u64), 17)));
            for k in 0..per_batch {
                let p = point(k, per_batch, &shift);
                let film = glam::Vec2::new(
                    (x as f64 + p[0]) as f32 / self.width as f32,
                    (y as f64 + p[1]) as f32 / self.height as f32,
                );
                let ray = self.camera.ray(film);
                let t = self.sphere.intersect(&ray);
                if !t.is_finite() {
                    let l = self.env.eval(ray.d.normalize());
                    let l = [l.r as f64, l.g as f64, l.b as f64];
                    add(&mut set.background[b], l, 1.0 / per_batch as f64);
                    continue;
                }
                let strategy = match k % 4 {
                    0 | 1 => 0,
                    2 => 1,
                    _ => 2,
                };
                let Some(d) = self.direction(data, ray.o + ray.d * t, ray.d, strategy, &p) else {
                    continue;
                };
                let (l, p_env) = self.env.eval_pdf(d.world);
                let l = [l.r as f64, l.g as f64, l.b as f64];
                if !l.iter().any(|&v| v > 0.0) {
                    continue;
                }
                set.batch.push(b);
                set.wo.push(d.wo);
                set.wi.push(d.wi);
                set.radiance.push(l);
                set.density.push(
                    counts[0] as f64 * p_env as f64
                        + counts[2] as f64 * mirror_cones::pdf(d.mirror, d.wi.as_dvec3()),
                );
            }
        }
        set
    }

    /// The direction of `strategy` (0 map, 1 data, 2 cones) at the hit `p` of a ray along
    /// `d`; None where it adds nothing (below the surface, nothing drawn).
    fn direction(
        &self,
        data: &dyn Bsdf,
        p: glam::Vec3,
        d: glam::Vec3,
        strategy: usize,
        pt: &[f64; 5],
    ) -> Option<Drawn> {
        let (_, n, dpdu) = self.sphere.surface(p);
        let frame = Frame::from_normal_tangent(n, dpdu);
        let wo = frame.to_local(-d).normalize();
        if wo.z <= 0.0 {
            return None;
        }
        let u = glam::Vec2::new(
            (pt[2] as f32).min(1.0 - f32::EPSILON),
            (pt[3] as f32).min(1.0 - f32::EPSILON),
        );
        let mirror = glam::DVec3::new(-wo.x as f64, -wo.y as f64, wo.z as f64);
        let wi = match strategy {
            0 => frame.to_local(self.env.sample(u)?.0).normalize(),
            1 => data.sample(wo, u, pt[4] as f32)?.wi,
            _ => {
                let e = mirror_cones::EXPONENTS[((pt[4] * 4.0) as usize).min(3)];
                mirror_cones::sample(mirror, e, [pt[2], pt[3]]).as_vec3()
            }
        };
        (wi.z > 0.0).then(|| Drawn {
            wo,
            wi,
            world: frame.to_world(wi).normalize(),
            mirror,
        })
    }
}

fn add(acc: &mut [f64; 3], v: [f64; 3], s: f64) {
    for c in 0..3 {
        acc[c] += v[c] * s;
    }
}

/// Sums over pixels (in pixel order) of one pass, per representation: the unbiased
/// squared difference `u`, the noise `v`, and both with each batch left out.
#[derive(Clone, Debug, Default)]
struct Sums {
    u: Vec<f64>,
    v: Vec<f64>,
    u_loo: Vec<f64>,
    v_loo: Vec<f64>,
    /// The data image's sum of squares (its scale).
    data_sq: f64,
}

impl Sums {
    fn new(m: usize, batches: usize) -> Self {
        Self {
            u: vec![0.0; m],
            v: vec![0.0; m],
            u_loo: vec![0.0; m * batches],
            v_loo: vec![0.0; m * batches],
            data_sq: 0.0,
        }
    }

    fn merge(mut self, o: &Sums) -> Self {
        let pairs = [
            (&mut self.u, &o.u),
            (&mut self.v, &o.v),
            (&mut self.u_loo, &o.u_loo),
            (&mut self.v_loo, &o.v_loo),
        ];
        for (a, b) in pairs {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
        self.data_sq += o.data_sq;
        self
    }

    /// Adds one pixel channel's batch values `d` (a difference, or the data's own values
    /// for representation 0) of representation `r`.
    fn add(&mut self, r: usize, d: &[f64]) {
        let b = d.len();
        let nb = b as f64;
        let mean = d.iter().sum::<f64>() / nb;
        let ss: f64 = d.iter().map(|x| (x - mean).powi(2)).sum();
        let var = ss / (nb - 1.0);
        self.u[r] += mean * mean - var / nb;
        self.v[r] += var / nb;
        let n = nb - 1.0;
        for (k, x) in d.iter().enumerate() {
            // Leave batch k out: the others' mean and sample variance.
            let c = x - mean;
            let shift = -c / n;
            let ss_k = ss - c * c - n * shift * shift;
            let var_k = ss_k / (n - 1.0);
            let m_k = mean + shift;
            self.u_loo[r * b + k] += m_k * m_k - var_k / n;
            // The noise of a B-batch mean, estimated from B - 1 batches.
            self.v_loo[r * b + k] += var_k / nb;
        }
    }
}

/// Student's t quantile at 0.975 for `dof` degrees of freedom.
fn t975(dof: usize) -> f64 {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    StudentsT::new(0.0, 1.0, dof.max(1) as f64)
        .map(|t| t.inverse_cdf(0.975))
        .unwrap_or(1.959_964)
}

/// The delete-one jackknife interval (95 %, Student's t) of a statistic `full` with
/// leave-one-out values `loo`.
fn jackknife(full: f64, loo: &[f64]) -> [f64; 2] {
    let b = loo.len() as f64;
    let mean = loo.iter().sum::<f64>() / b;
    let var = (b - 1.0) / b * loo.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
    let half = t975(loo.len() - 1) * var.sqrt();
    [full - half, full + half]
}

/// Square root of a mean square clamped at zero.
fn root(x: f64) -> f64 {
    x.max(0.0).sqrt()
}

/// A pixel's mean and the variance of that mean, per channel.
type Moments = ([f32; 3], [f32; 3]);

/// One pass at `spp` samples per pixel: the batch sums and the mean images (the data's
/// two halves appended).
fn pass(
    stage: &Stage<'_>,
    reps: &[&dyn Bsdf],
    settings: &ErrorSettings,
    spp: usize,
    seed: u64,
) -> (Sums, Vec<Vec<Moments>>) {
    let m = reps.len();
    let batches = settings.batches;
    let per_batch = spp / batches;
    let (w, h) = (stage.width, stage.height);
    let rows: Vec<(Sums, Vec<Vec<Moments>>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut sums = Sums::new(m, batches);
            let mut images = vec![Vec::with_capacity(w as usize); m + 2];
            let mut d = vec![0.0; batches];
            for x in 0..w {
                let px = stage.pixel(reps, (x, y), (per_batch, batches), seed);
                let value = |r: usize, b: usize, c: usize| px[r * batches + b][c];
                for c in 0..3 {
                    for r in 0..m {
                        for (b, db) in d.iter_mut().enumerate() {
                            *db = match r {
                                0 => value(0, b, c),
                                _ => value(r, b, c) - value(0, b, c),
                            };
                        }
                        sums.add(r, &d);
                    }
                }
                let moments = |r: usize, bs: std::ops::Range<usize>| -> Moments {
                    let n = bs.len() as f64;
                    let mean: [f64; 3] = std::array::from_fn(|c| {
                        bs.clone().map(|b| value(r, b, c)).sum::<f64>() / n
                    });
                    let var: [f64; 3] = std::array::from_fn(|c| {
                        let ss: f64 = bs.clone().map(|b| (value(r, b, c) - mean[c]).powi(2)).sum();
                        ss / (n - 1.0) / n
                    });
                    (mean.map(|v| v as f32), var.map(|v| v as f32))
                };
                for (r, img) in images.iter_mut().enumerate().take(m) {
                    img.push(moments(r, 0..batches));
                }
                images[m].push(moments(0, 0..batches / 2));
                images[m + 1].push(moments(0, batches / 2..batches));
                sums.data_sq += images[0]
                    .last()
                    .map_or(0.0, |p| p.0.iter().map(|&v| (v as f64).powi(2)).sum());
            }
            (sums, images)
        })
        .collect();
    let mut total = Sums::new(m, batches);
    let mut images = vec![Vec::with_capacity((w * h) as usize); m + 2];
    for (s, imgs) in &rows {
        total = total.merge(s);
        for (all, row) in images.iter_mut().zip(imgs) {
            all.extend_from_slice(row);
        }
    }
    (total, images)
}

/// The images, errors and noise of representations `reps` (`reps[0]` the measured data)
/// on `stage`, sampled until the targets of `settings` hold or the cap is reached.
pub fn estimate(
    stage: &Stage<'_>,
    reps: &[&dyn Bsdf],
    settings: &ErrorSettings,
) -> Result<SphereErrors, lobe_renderer::Error> {
    let b = settings.batches.max(4);
    let settings = ErrorSettings {
        batches: b,
        ..settings.clone()
    };
    let quantum = 4 * b;
    let round_up = |s: usize| s.div_ceil(quantum).max(1) * quantum;
    let max_spp = round_up(settings.max_spp);
    let mut spp = round_up(settings.pilot_spp).min(max_spp);
    let mut passes = 0;
    loop {
        passes += 1;
        let (sums, images) = pass(stage, reps, &settings, spp, settings.seed ^ passes as u64);
        let (mut out, halves) = summarize(stage, &sums, images, &settings);
        out.spp = spp;
        out.passes = passes;
        let factor = needed_factor(&out, &settings);
        if factor <= 1.0 || spp >= max_spp || passes >= 3 {
            add_flip(&mut out, &halves)?;
            return Ok(out);
        }
        spp = round_up((spp as f64 * factor * 1.2).ceil() as usize).min(max_spp);
    }
}

/// How many times more samples the targets call for (1 when met): every non-negligible
/// fit's own noise under `noise_ratio` of its error (so that its FLIP map shows its error
/// rather than noise), every interval narrower than `interval_ratio` of its error, and the
/// noise floor under `noise_ratio` of the smallest error.
fn needed_factor(out: &SphereErrors, s: &ErrorSettings) -> f64 {
    let fits: Vec<&RepError> = out.errors[1..].iter().filter(|e| !e.negligible).collect();
    let Some(smallest) = fits.iter().map(|e| e.rmse).min_by(f64::total_cmp) else {
        return 1.0;
    };
    let own = fits
        .iter()
        .map(|e| (e.noise / (s.noise_ratio * e.rmse)).powi(2))
        .fold(0.0, f64::max);
    let floor = (out.noise_floor / (s.noise_ratio * smallest)).powi(2);
    let width = fits
        .iter()
        .map(|e| (e.relative_width() / s.interval_ratio).powi(2))
        .fold(0.0, f64::max);
    own.max(floor).max(width)
}

/// The FLIP of every representation against the data's image at the common exposure
/// (for the data: between the images of its two halves of batches, `halves`), and the
/// maps; computed for the reported pass only.
fn add_flip(out: &mut SphereErrors, halves: &[Image; 2]) -> Result<(), lobe_renderer::Error> {
    out.flip_maps.clear();
    for r in 0..out.images.len() {
        let (against, test) = match r {
            0 => (&halves[0], &halves[1]),
            _ => (&out.images[0], &out.images[r]),
        };
        let (mt, map) = metrics(test, against, out.exposure)?;
        out.errors[r].flip = mt.flip;
        out.flip_maps.push(map);
    }
    Ok(())
}

/// The errors (FLIP not yet: [`add_flip`]) and pictures of one pass's sums and images,
/// and the data's images of its two halves of batches.
fn summarize(
    stage: &Stage<'_>,
    sums: &Sums,
    mut images: Vec<Vec<Moments>>,
    s: &ErrorSettings,
) -> (SphereErrors, [Image; 2]) {
    let b = s.batches;
    let (w, h) = (stage.width, stage.height);
    let n = 3.0 * (w as f64) * (h as f64);
    let to_image = |px: Vec<Moments>| Image {
        width: w,
        height: h,
        pixels: px.iter().map(|p| Rgb::from(p.0)).collect(),
        variance: px.iter().map(|p| Rgb::from(p.1)).collect(),
        variance_dof: (b - 1) as f64,
    };
    let half_b = to_image(images.pop().unwrap_or_default());
    let half_a = to_image(images.pop().unwrap_or_default());
    let images: Vec<Image> = images.into_iter().map(to_image).collect();
    let exposure = exposure_for(&images[0]);
    let data_rms = (sums.data_sq / n).sqrt();
    let mut errors = Vec::new();
    for r in 0..images.len() {
        let loo = |v: &[f64]| -> Vec<f64> { v[r * b..(r + 1) * b].iter().map(|x| x / n).collect() };
        let noise = root(sums.v[r] / n);
        let (rmse, ci) = match r {
            0 => (noise, jackknife(sums.v[0] / n, &loo(&sums.v_loo))),
            _ => (
                root(sums.u[r] / n),
                jackknife(sums.u[r] / n, &loo(&sums.u_loo)),
            ),
        };
        errors.push(RepError {
            rmse,
            ci95: [root(ci[0]), root(ci[1])],
            noise,
            flip: f64::NAN,
            negligible: r > 0 && rmse < s.negligible * data_rms,
        });
    }
    let noise_floor = errors[1..].iter().map(|e| e.noise).fold(0.0, f64::max);
    let fits: Vec<&RepError> = errors[1..].iter().filter(|e| !e.negligible).collect();
    let smallest = fits.iter().map(|e| e.rmse).fold(f64::INFINITY, f64::min);
    let out = SphereErrors {
        noise_target_met: noise_floor <= s.noise_ratio * smallest,
        interval_target_met: fits.iter().all(|e| e.relative_width() <= s.interval_ratio),
        images,
        errors,
        flip_maps: Vec::new(),
        noise_floor,
        spp: 0,
        batches: b,
        passes: 0,
        exposure,
    };
    (out, [half_a, half_b])
}

/// The exposure (stops) at which under 1 % of the image's pixels clip: the 99.5th
/// percentile of its largest channel maps to 1 (0 stops for a black image).
pub fn exposure_for(img: &Image) -> f32 {
    let mut v: Vec<f32> = img
        .pixels
        .iter()
        .map(|p| p.max_component())
        .filter(|x| x.is_finite())
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    let k = ((v.len() as f64 * 0.995) as usize).min(v.len() - 1);
    let (_, p99, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    match *p99 > 0.0 {
        true => (-p99.log2()).clamp(-20.0, 20.0),
        false => 0.0,
    }
}
