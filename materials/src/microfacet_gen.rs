//! The microfacet-based BRDF generator of Ashikhmin, Premože and Shirley (SIGGRAPH 2000)
//! with a tabulated distribution of normals, and its estimation from measurements (Ngan et
//! al. 2005, section 5, Eq. 3 and 4).
//!
//! Forward model (APS2000, with p normalized so that <h.n> = int p(h) (h.n) dw = 1):
//!
//!   rho(k1, k2) = p(h) <h.n> F(k.h) / (4 g(k1) g(k2)),   g(k) = int (h.k)+ p(h) dw_h,
//!
//! g being APS2000's shadowing term (the projected area of the microfacets facing k). For
//! a Smith microsurface g(k) = (k.n)(1 + Lambda(k)), so with a Beckmann p the generator is
//! Cook-Torrance with Beckmann D and separable Smith shadowing G1(k1) G1(k2) exactly
//! (tested). F is Schlick's with `f0` (1: no Fresnel).
//!
//! Table: p is stored at the nodes of an N x N grid over the projected hemisphere,
//! (h_x, h_y) in [-1, 1]^2 (zero outside the unit disk), and interpolated bilinearly. The
//! projected parameterization resolves a ridge along a great circle through the normal
//! (brushed metal) as a straight line, and its node spacing 2 / (N - 1) is 0.45 degrees at
//! the pole for the default N = 257 (the narrow ridges of section 5.1 are 3 to 5 degrees
//! wide); it coarsens towards the horizon, where distributions are small and the data stop
//! at 80 degrees anyway. Because dw = dA / h_z, the bilinear table is itself the density of
//! h over the disk with respect to p(h) h_z dw: normalizing it to unit integral over the
//! disk normalizes <h.n>, and the continuous 2D sampler (`Marginal2D`) draws h with density
//! p(h) h_z exactly. g(k) is tabulated over (theta_k, phi_k) on 2 x 5 degree nodes by
//! quadrature over the same grid.
//!
//! Estimation (Ngan et al. Eq. 4): p(h) = rho(k1, k2) 4 g(k1) g(k2) / (<h.n> F(k.h)),
//! averaged over all measured pairs whose half vector falls near each node (bilinear
//! splatting), starting from g = 1 and alternating the estimates of p and g; empty nodes
//! inside the disk take the mean of their filled neighbours. A constant diffuse term is
//! estimated with the colours by the fitter's non-negative least squares and subtracted in
//! a second round; `f0` is given or found by a golden-section search on the Eq. (1) error.

use crate::composite::Composite;
use crate::fit::dataset::Dataset;
use crate::lobe::{Lobe, half_to_incident_pdf, sample_via_half};
use crate::measured::marginal2d::Marginal2D;
use crate::registry::{
    Bounds, BuildContext, DefaultValue, ModelSchema, ParamKind, ParamRole, ParamSpec, Params,
    Registry,
};
use crate::{Bsdf, Flags, ParamError, Rgb};
use glam::{DVec3, Vec2, Vec3};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Default nodes per side of the distribution table.
pub const DEFAULT_RES: usize = 257;
/// Nodes of the g(k) table: theta_k every 2 degrees, phi_k every 5 degrees.
const G_THETA: usize = 46;
const G_PHI: usize = 73;

/// Closed-form or synthetic distributions of normals (unnormalized densities over the
/// hemisphere with respect to solid angle).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Anisotropic Beckmann: exp(-(hx^2/ax^2 + hy^2/ay^2)/hz^2) / (pi ax ay hz^4).
    Beckmann { alpha_x: f64, alpha_y: f64 },
    /// Brushed metal: a ridge of angular width `width` (radians) along the great circle
    /// through the normal perpendicular to x (the brushing direction is y), fading with
    /// angle from the normal over `falloff` radians.
    Brushed { width: f64, falloff: f64 },
    /// Satin: two such ridges along great circles tilted by +-`tilt` from the vertical.
    Satin { width: f64, tilt: f64, falloff: f64 },
    /// Velvet: a main lobe around the normal of width `main` plus a secondary ring at
    /// `ring` radians from the normal, of width `ring_width` and relative weight `weight`.
    Velvet {
        main: f64,
        ring: f64,
        ring_width: f64,
        weight: f64,
    },
}

impl Shape {
    /// The three structures of section 5.1 as used by the tests and `lobe microfacet synth`.
    pub fn synthetic(name: &str) -> Option<Shape> {
        let deg = |d: f64| d.to_radians();
        Some(match name {
            "brushed" => Shape::Brushed {
                width: deg(3.0),
                falloff: deg(35.0),
            },
            "satin" => Shape::Satin {
                width: deg(5.0),
                tilt: deg(25.0),
                falloff: deg(45.0),
            },
            "velvet" => Shape::Velvet {
                main: deg(12.0),
                ring: deg(62.0),
                ring_width: deg(8.0),
                weight: 0.25,
            },
            _ => return None,
        })
    }

    pub fn density(&self, h: DVec3) -> f64 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let theta = h.z.clamp(-1.0, 1.0).acos();
        let ridge = |axis: DVec3, width: f64| {
            let off = h.dot(axis).clamp(-1.0, 1.0).asin();
            (-(off / width).powi(2)).exp()
        };
        match *self {
            Shape::Beckmann { alpha_x, alpha_y } => {
                let e = (h.x * h.x / (alpha_x * alpha_x) + h.y * h.y / (alpha_y * alpha_y))
                    / (h.z * h.z);
                (-e).exp() / (PI * alpha_x * alpha_y * h.z.powi(4))
            }
            Shape::Brushed { width, falloff } => {
                ridge(DVec3::X, width) * (-(theta / falloff).powi(2)).exp()
            }
            Shape::Satin {
                width,
                tilt,
                falloff,
            } => {
                let (s, c) = tilt.sin_cos();
                (ridge(DVec3::new(c, 0.0, s), width) + ridge(DVec3::new(c, 0.0, -s), width))
                    * (-(theta / falloff).powi(2)).exp()
            }
            Shape::Velvet {
                main,
                ring,
                ring_width,
                weight,
            } => {
                (-(theta / main).powi(2)).exp()
                    + weight * (-((theta - ring) / ring_width).powi(2)).exp()
            }
        }
    }
}

/// A tabulated distribution of normals with its shadowing table and sampler.
#[derive(Clone, Debug)]
pub struct Table {
    n: usize,
    /// Node values of p, normalized: sum p * cell^2 = 1 (so <h.n> = 1).
    p: Vec<f32>,
    /// g(k) at (theta, phi) nodes.
    g: Vec<f32>,
    sampler: Marginal2D,
}

fn node_dir(n: usize, i: usize, j: usize) -> Option<DVec3> {
    let s = 2.0 / (n - 1) as f64;
    let (x, y) = (-1.0 + i as f64 * s, -1.0 + j as f64 * s);
    let r2 = x * x + y * y;
    (r2 < 1.0).then(|| DVec3::new(x, y, (1.0 - r2).sqrt()))
}

fn g_dir(t: usize, f: usize) -> DVec3 {
    let theta = (t as f64 * 2.0).to_radians().min(89.9f64.to_radians());
    let phi = (f as f64 * 5.0).to_radians();
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

impl Table {
    /// Tabulates `f` (any non-negative density, normalized here) on `n` x `n` nodes.
    pub fn from_fn(n: usize, f: impl Fn(DVec3) -> f64 + Sync) -> Result<Table, String> {
        use rayon::prelude::*;
        let nodes: Vec<f64> = (0..n * n)
            .into_par_iter()
            .map(|k| node_dir(n, k % n, k / n).map_or(0.0, &f))
            .collect();
        Table::from_nodes(n, nodes)
    }

    /// A table from node values (row-major, y rows of x); normalized here.
    pub fn from_nodes(n: usize, mut nodes: Vec<f64>) -> Result<Table, String> {
        if n < 3 || nodes.len() != n * n {
            return Err(format!(
                "distribution table: {} values for {n} x {n} nodes; expected n >= 3 and n^2 values",
                nodes.len()
            ));
        }
        for (k, v) in nodes.iter_mut().enumerate() {
            if !v.is_finite() || *v < 0.0 {
                return Err(format!(
                    "distribution table: node {k} holds {v}; expected a finite non-negative density"
                ));
            }
            if node_dir(n, k % n, k / n).is_none() {
                *v = 0.0;
            }
        }
        let cell = 2.0 / (n - 1) as f64;
        let total: f64 = nodes.iter().sum::<f64>() * cell * cell;
        if !(total > 0.0) {
            return Err("distribution table: every node inside the disk is zero; expected a positive density".into());
        }
        let p: Vec<f32> = nodes.iter().map(|v| (v / total) as f32).collect();
        let g = compute_g(n, &p);
        let sampler = Marginal2D::new(&p, n, n, Vec::new(), true);
        Ok(Table { n, p, g, sampler })
    }

    pub fn resolution(&self) -> usize {
        self.n
    }

    /// Normalized node values (row-major, y rows of x).
    pub fn nodes(&self) -> &[f32] {
        &self.p
    }

    /// p(h), bilinear between nodes (h need not be normalized to the disk exactly).
    #[inline]
    pub fn p(&self, hx: f64, hy: f64) -> f64 {
        if hx * hx + hy * hy >= 1.0 {
            return 0.0;
        }
        let s = (self.n - 1) as f64 / 2.0;
        let (px, py) = ((hx + 1.0) * s, (hy + 1.0) * s);
        let (ix, iy) = ((px as usize).min(self.n - 2), (py as usize).min(self.n - 2));
        let (fx, fy) = (px - ix as f64, py - iy as f64);
        let at = |x: usize, y: usize| self.p[y * self.n + x] as f64;
        (1.0 - fy) * ((1.0 - fx) * at(ix, iy) + fx * at(ix + 1, iy))
            + fy * ((1.0 - fx) * at(ix, iy + 1) + fx * at(ix + 1, iy + 1))
    }

    /// g(k) from its table, bilinear in (theta, phi).
    #[inline]
    pub fn g(&self, k: DVec3) -> f64 {
        let theta = k.z.clamp(-1.0, 1.0).acos().to_degrees().min(89.9) / 2.0;
        let mut phi = k.y.atan2(k.x).to_degrees();
        if phi < 0.0 {
            phi += 360.0;
        }
        let phi = phi / 5.0;
        let (it, ip) = (
            (theta as usize).min(G_THETA - 2),
            (phi as usize).min(G_PHI - 2),
        );
        let (ft, fp) = (theta - it as f64, phi - ip as f64);
        let at = |t: usize, f: usize| self.g[t * G_PHI + f] as f64;
        (1.0 - ft) * ((1.0 - fp) * at(it, ip) + fp * at(it, ip + 1))
            + ft * ((1.0 - fp) * at(it + 1, ip) + fp * at(it + 1, ip + 1))
    }

    /// The generator's value per unit specular colour.
    #[inline]
    pub fn rho(&self, wo: DVec3, wi: DVec3, f0: f64) -> f64 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize_or_zero();
        if h.z <= 0.0 {
            return 0.0;
        }
        let c = wi.dot(h).clamp(0.0, 1.0);
        let fresnel = f0 + (1.0 - f0) * (1.0 - c).powi(5);
        let v = self.p(h.x, h.y) * fresnel / (4.0 * self.g(wo) * self.g(wi));
        if v.is_finite() { v.max(0.0) } else { 0.0 }
    }

    /// Density of h with respect to solid angle of `sample_h`: p(h) h_z.
    pub fn pdf_h(&self, h: DVec3) -> f64 {
        if h.z <= 0.0 {
            0.0
        } else {
            self.p(h.x, h.y) * h.z
        }
    }

    /// Draws h with density p(h) h_z (None when the bilinear density leaks past the rim).
    pub fn sample_h(&self, u: Vec2) -> Option<Vec3> {
        let (uv, _) = self.sampler.sample([u.x, u.y], &[]);
        let (x, y) = (2.0 * uv[0] - 1.0, 2.0 * uv[1] - 1.0);
        let r2 = x * x + y * y;
        (r2 < 1.0).then(|| Vec3::new(x, y, (1.0 - r2).sqrt()))
    }

    /// Reads a distribution written by [`Table::write_exr`] (any square EXR; the first
    /// channel's values are the node densities, row 0 at h_y = -1).
    pub fn read_exr(path: &Path) -> Result<Table, String> {
        use exr::prelude::*;
        let name = path.display();
        crate::io::check_exr_size(path).map_err(|m| format!("{name}: {m}"))?;
        let img = crate::guard::third_party("OpenEXR", || {
            read_first_rgba_layer_from_file(
                path,
                |res, _| (res.width(), vec![0.0f64; res.width() * res.height()]),
                |(w, px): &mut (usize, Vec<f64>), pos, (r, _g, _b, _a): (f32, f32, f32, f32)| {
                    px[pos.y() * *w + pos.x()] = r as f64;
                },
            )
        })
        .map_err(|m| format!("{name}: {m}"))?
        .map_err(|e| format!("{name}: cannot read the distribution EXR: {e}"))?;
        let (w, px) = img.layer_data.channel_data.pixels;
        if w * w != px.len() {
            return Err(format!(
                "{name}: {} x {} pixels; expected a square distribution table",
                w,
                px.len() / w.max(1)
            ));
        }
        Table::from_nodes(w, px).map_err(|e| format!("{name}: {e}"))
    }

    /// Writes the table as an EXR file (temporary file renamed into place) that
    /// [`Table::read_exr`] and the `sampled-microfacet` material read.
    pub fn write_exr(&self, path: &Path) -> Result<(), crate::FileError> {
        let bytes = self
            .exr_bytes()
            .map_err(|e| crate::FileError::new(path.display().to_string(), e))?;
        crate::io::atomic_write(path, |w| std::io::Write::write_all(w, &bytes))
    }

    /// The node values as an EXR image (equal RGB channels).
    pub fn exr_bytes(&self) -> Result<Vec<u8>, String> {
        use exr::prelude::*;
        let n = self.n;
        let channels = SpecificChannels::rgb(|pos: exr::math::Vec2<usize>| {
            let v = self.p[pos.y() * n + pos.x()];
            (v, v, v)
        });
        let image = exr::image::Image::from_channels((n, n), channels);
        let mut buf = std::io::Cursor::new(Vec::new());
        image
            .write()
            .to_buffered(&mut buf)
            .map_err(|e| e.to_string())?;
        Ok(buf.into_inner())
    }
}

/// g(k) = int (h.k)+ p(h) dw = int_disk (h.k)+ p(h) / h_z dA on the (theta, phi) nodes.
fn compute_g(n: usize, p: &[f32]) -> Vec<f32> {
    use rayon::prelude::*;
    let cell = 2.0 / (n - 1) as f64;
    let nodes: Vec<(DVec3, f64)> = (0..n * n)
        .filter_map(|k| {
            let v = p[k] as f64;
            if v <= 0.0 {
                return None;
            }
            node_dir(n, k % n, k / n).map(|h| (h, v * cell * cell / h.z.max(1e-3)))
        })
        .collect();
    (0..G_THETA * G_PHI)
        .into_par_iter()
        .map(|k| {
            let d = g_dir(k / G_PHI, k % G_PHI);
            let s: f64 = nodes.iter().map(|(h, w)| h.dot(d).max(0.0) * w).sum();
            s.max(1e-6) as f32
        })
        .collect()
}

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
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        Rgb::splat(self.table.rho(wo.as_dvec3(), wi.as_dvec3(), self.f0) as f32)
    }
    fn eval_f64(&self, wo: DVec3, wi: DVec3) -> [f64; 3] {
        [self.table.rho(wo, wi, self.f0); 3]
    }
    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<Vec3> {
        sample_via_half(wo, self.table.sample_h(u)?)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize_or_zero();
        let p = half_to_incident_pdf(self.table.pdf_h(h.as_dvec3()) as f32, wo.dot(h));
        if p.is_finite() { p } else { 0.0 }
    }
    fn flags(&self) -> Flags {
        Flags::RECIPROCAL | Flags::GLOSSY
    }
    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self)
            + (self.table.p.len() + self.table.g.len()) * 4
            + self.table.sampler.memory_bytes()
    }
}

/// The result of estimating a distribution from measured data.
#[derive(Clone, Debug)]
pub struct Estimate {
    pub table: Arc<Table>,
    pub f0: f64,
    pub diffuse: [f64; 3],
    pub specular: [f64; 3],
    /// Eq. (1) error of the generator with these colours on the data.
    pub error: f64,
    /// Relative L2 change of p at each iteration of the last round.
    pub changes: Vec<f64>,
}

impl Estimate {
    /// The material description (with the distribution file given).
    pub fn material(&self, file: &str) -> serde_json::Value {
        serde_json::json!({
            "type": "sampled-microfacet",
            "distribution": file,
            "f0": self.f0,
            "diffuse": self.diffuse,
            "specular": self.specular,
        })
    }
}

/// One estimate of p from the data (diffuse removed), with the given g, by Eq. (4).
fn estimate_p(
    data: &Dataset,
    n: usize,
    g: &(dyn Fn(DVec3) -> f64 + Sync),
    f0: f64,
    diffuse_lum: f64,
) -> Vec<f64> {
    use rayon::prelude::*;
    let s = (n - 1) as f64 / 2.0;
    // Isotropic data hold one azimuth of each configuration (wi at phi = 0, wo at phi_d in
    // [0, 180]): spread every pair over 8 rotations and their mirror images so that p is
    // estimated over the whole disk.
    type Rot = Box<dyn Fn(DVec3) -> DVec3 + Sync>;
    let rotations: Vec<Rot> = if data.anisotropic {
        vec![Box::new(|k| k)]
    } else {
        (0..8)
            .flat_map(|j| {
                let (sn, cs) = (j as f64 * PI / 4.0).sin_cos();
                [false, true].map(move |mirror| -> Rot {
                    Box::new(move |k: DVec3| {
                        let y = if mirror { -k.y } else { k.y };
                        DVec3::new(cs * k.x - sn * y, sn * k.x + cs * y, k.z)
                    })
                })
            })
            .collect()
    };
    let (acc, wsum) = data
        .samples
        .par_chunks(8192)
        .map(|chunk| {
            let mut acc = vec![0.0f64; n * n];
            let mut wsum = vec![0.0f64; n * n];
            for (smp, rot) in chunk
                .iter()
                .flat_map(|s| rotations.iter().map(move |r| (s, r)))
            {
                let (k1, k2) = (rot(smp.wi.as_dvec3()), rot(smp.wo.as_dvec3()));
                let h = (k1 + k2).normalize_or_zero();
                if h.z <= 0.0 {
                    continue;
                }
                let c = k1.dot(h).clamp(0.0, 1.0);
                let fresnel = f0 + (1.0 - f0) * (1.0 - c).powi(5);
                let rho = (smp.value.iter().sum::<f64>() / 3.0 - diffuse_lum / PI).max(0.0);
                let v = rho * 4.0 * g(k1) * g(k2) / fresnel.max(1e-6);
                let (px, py) = ((h.x + 1.0) * s, (h.y + 1.0) * s);
                let (ix, iy) = ((px as usize).min(n - 2), (py as usize).min(n - 2));
                let (fx, fy) = (px - ix as f64, py - iy as f64);
                for (dx, dy, w) in [
                    (0, 0, (1.0 - fx) * (1.0 - fy)),
                    (1, 0, fx * (1.0 - fy)),
                    (0, 1, (1.0 - fx) * fy),
                    (1, 1, fx * fy),
                ] {
                    let k = (iy + dy) * n + ix + dx;
                    acc[k] += w * v;
                    wsum[k] += w;
                }
            }
            (acc, wsum)
        })
        .reduce(
            || (vec![0.0; n * n], vec![0.0; n * n]),
            |mut a, b| {
                for k in 0..n * n {
                    a.0[k] += b.0[k];
                    a.1[k] += b.1[k];
                }
                a
            },
        );
    let inside = |k: usize| node_dir(n, k % n, k / n).is_some();
    let mut p: Vec<Option<f64>> = (0..n * n)
        .map(|k| (inside(k) && wsum[k] > 1e-9).then(|| acc[k] / wsum[k]))
        .collect();
    // Fill empty nodes inside the disk from their filled neighbours, ring by ring.
    for _ in 0..2 * n {
        let missing: Vec<usize> = (0..n * n)
            .filter(|&k| inside(k) && p[k].is_none())
            .collect();
        if missing.is_empty() {
            break;
        }
        let fills: Vec<(usize, f64)> = missing
            .iter()
            .filter_map(|&k| {
                let (x, y) = ((k % n) as i64, (k / n) as i64);
                let mut sum = 0.0;
                let mut cnt = 0;
                for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                    let (a, b) = (x + dx, y + dy);
                    if a >= 0
                        && b >= 0
                        && a < n as i64
                        && b < n as i64
                        && let Some(v) = p[(b as usize) * n + a as usize]
                    {
                        sum += v;
                        cnt += 1;
                    }
                }
                (cnt > 0).then(|| (k, sum / cnt as f64))
            })
            .collect();
        if fills.is_empty() {
            break;
        }
        for (k, v) in fills {
            p[k] = Some(v);
        }
    }
    p.into_iter().map(|v| v.unwrap_or(0.0)).collect()
}

/// Alternates the estimates of p and g (at most `iterations` times) for a given f0 and
/// diffuse level; returns the table and the change per iteration.
fn alternate(
    data: &Dataset,
    n: usize,
    f0: f64,
    diffuse_lum: f64,
    iterations: usize,
) -> Result<(Arc<Table>, Vec<f64>), String> {
    let mut table: Option<Arc<Table>> = None;
    let mut changes = Vec::new();
    for _ in 0..iterations.max(1) {
        let nodes = match &table {
            None => estimate_p(data, n, &|_| 1.0, f0, diffuse_lum),
            Some(t) => estimate_p(data, n, &|k| t.g(k), f0, diffuse_lum),
        };
        let next = Arc::new(Table::from_nodes(n, nodes)?);
        if let Some(prev) = &table {
            let (mut d, mut s) = (0.0f64, 0.0f64);
            for (a, b) in next.p.iter().zip(&prev.p) {
                d += ((a - b) as f64).powi(2);
                s += (*a as f64).powi(2);
            }
            let change = (d / s.max(1e-300)).sqrt();
            changes.push(change);
            table = Some(next);
            if change < 1e-3 {
                break;
            }
        } else {
            table = Some(next);
        }
    }
    Ok((table.expect("one iteration"), changes))
}

/// Colours and Eq. (1) error of a table on the data.
fn colours(data: &Dataset, table: &Arc<Table>, f0: f64) -> (f64, [f64; 3], [f64; 3]) {
    let lobe: Arc<dyn Lobe> = Arc::new(SampledMicrofacet {
        table: table.clone(),
        f0,
    });
    let (e, c) = crate::fit::linear_colours(data, &[lobe]);
    (e, c[0], c[1])
}

/// Estimates the distribution from measured data (Ngan et al. section 5): `n` nodes per
/// side, at most `iterations` alternations of p and g per round, two rounds (the second
/// with the estimated diffuse removed); `f0` given, or found by golden-section search.
pub fn estimate(
    data: &Dataset,
    n: usize,
    f0: Option<f64>,
    iterations: usize,
) -> Result<Estimate, String> {
    data.check()?;
    let run = |f0: f64| -> Result<Estimate, String> {
        let (t1, _) = alternate(data, n, f0, 0.0, iterations)?;
        let (_, d1, _) = colours(data, &t1, f0);
        let d_lum = (d1[0] + d1[1] + d1[2]) / 3.0;
        let (table, changes) = alternate(data, n, f0, d_lum, iterations)?;
        let (error, diffuse, specular) = colours(data, &table, f0);
        Ok(Estimate {
            table,
            f0,
            diffuse,
            specular,
            error,
            changes,
        })
    };
    match f0 {
        Some(f) => run(f),
        None => {
            // Golden-section search on [0, 1] (the error is unimodal in f0 in practice; the
            // end points are tried too).
            let phi = (5f64.sqrt() - 1.0) / 2.0;
            let (mut a, mut b) = (0.0f64, 1.0f64);
            let mut c = b - phi * (b - a);
            let mut d = a + phi * (b - a);
            let mut ec = run(c)?;
            let mut ed = run(d)?;
            for _ in 0..8 {
                if ec.error <= ed.error {
                    b = d;
                    d = c;
                    ed = ec;
                    c = b - phi * (b - a);
                    ec = run(c)?;
                } else {
                    a = c;
                    c = d;
                    ec = ed;
                    d = a + phi * (b - a);
                    ed = run(d)?;
                }
            }
            let mut best = if ec.error <= ed.error { ec } else { ed };
            for end in [1.0, 0.02] {
                let e = run(end)?;
                if e.error < best.error {
                    best = e;
                }
            }
            Ok(best)
        }
    }
}

/// Sparse anisotropic 4D data of `f(wi, wo)` (per channel, no cosine) as the study sampled
/// its anisotropic measurements: bins of `res_deg` in (theta_i, theta_o, phi_i, phi_o), a
/// fraction `filled` of them non-empty (chosen by a hash of the bin and `seed`), nothing
/// past 80 degrees, each bin weighted by sin(theta_i) sin(theta_o).
pub fn sparse_4d(
    f: &(dyn Fn(Vec3, Vec3) -> [f64; 3] + Sync),
    res_deg: f64,
    filled: f64,
    seed: u64,
) -> Dataset {
    use crate::fit::dataset::{CUTOFF_DEG, Sample};
    use crate::measured::tabulate::Acquisition;
    use rayon::prelude::*;
    let acq = Acquisition {
        empty_fraction: 1.0 - filled,
        seed,
        ..Default::default()
    };
    let nt = (CUTOFF_DEG / res_deg).floor() as usize;
    let np = (360.0 / res_deg).round() as usize;
    use crate::fit::dataset::dir;
    let samples: Vec<Sample> = (0..nt * nt * np)
        .into_par_iter()
        .flat_map_iter(|k| {
            let (ti, to, pi) = (k / (nt * np), (k / np) % nt, k % np);
            let (ti, to, pi) = (
                (ti as f64 + 0.5) * res_deg,
                (to as f64 + 0.5) * res_deg,
                (pi as f64 + 0.5) * res_deg,
            );
            let wi = dir(ti, pi);
            let ci = ti.to_radians().cos();
            let w = ti.to_radians().sin() * to.to_radians().sin();
            (0..np).filter_map(move |po| {
                if acq.bin_empty((k * np + po) as u64) {
                    return None;
                }
                let wo = dir(to, (po as f64 + 0.5) * res_deg);
                Some(Sample {
                    wi,
                    wo,
                    value: f(wi, wo),
                    weight: w,
                    cos2: ci * ci,
                })
            })
        })
        .collect();
    let max_albedo = Dataset::albedo_of(&|wi, wo| {
        let v = f(wi, wo);
        Some(Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32))
    });
    Dataset {
        samples,
        anisotropic: true,
        max_albedo,
    }
}

/// Pearson correlation of two tables' node values inside the disk (same resolution).
pub fn correlation(a: &Table, b: &Table) -> f64 {
    assert_eq!(a.n, b.n);
    let pairs: Vec<(f64, f64)> = (0..a.n * a.n)
        .filter(|&k| node_dir(a.n, k % a.n, k / a.n).is_some())
        .map(|k| (a.p[k] as f64, b.p[k] as f64))
        .collect();
    let m = pairs.len() as f64;
    let (ma, mb) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / m,
        pairs.iter().map(|p| p.1).sum::<f64>() / m,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt().max(1e-300)
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
