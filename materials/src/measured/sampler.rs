//! Importance sampling of tabulated isotropic BRDFs (MERL, binned, RGL tables): for each of
//! 32 bins of theta_o, a piecewise-constant distribution over the incident hemisphere on a
//! 90 (theta_i, 1 degree) x 90 (phi_i - phi_o in [0, pi], 2 degrees, mirrored by isotropy)
//! grid, each cell weighted by the largest luminance x cos(theta_i) x solid angle found on a
//! 3 x 3 grid of the cell for both edges of the theta_o bin (so narrow highlights are not
//! missed), sampled by CDF inversion (which keeps low-discrepancy samples stratified), mixed with 10 % cosine sampling so that every
//! direction where the table is non-zero can be drawn. Within a cell, directions are
//! uniform in solid angle. The density is exact for what is sampled, so the estimator is
//! unbiased whatever the table's accuracy. Angles at render time come from [`fastmath`]
//! (no C library call per query).

use crate::fastmath::{self, xn};
use crate::sampling::cdf::Cdf2D;
use crate::sampling::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::simd::{self, Vec3xN, f32xn, i32xn, sel};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};

const N_THETA_O: usize = 32;
const N_THETA: usize = 90;
const N_PHI: usize = 90;
const COSINE_FRACTION: f32 = 0.1;

#[derive(Clone, Debug)]
pub struct TabulatedSampler {
    /// One cell sampler per theta_o bin (None when the slice is black).
    tables: Vec<Option<Cdf2D>>,
    /// Per theta_o bin, per cell: probability / solid angle of the cell (both mirror halves).
    density: Vec<f32>,
}

fn cell_bounds(it: usize, ip: usize) -> (f32, f32, f32, f32) {
    let t0 = it as f32 / N_THETA as f32 * FRAC_PI_2;
    let t1 = (it + 1) as f32 / N_THETA as f32 * FRAC_PI_2;
    let p0 = ip as f32 / N_PHI as f32 * PI;
    let p1 = (ip + 1) as f32 / N_PHI as f32 * PI;
    (t0, t1, p0, p1)
}

fn dir(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

impl TabulatedSampler {
    pub fn memory_bytes(&self) -> usize {
        self.density.len() * 4
            + self
                .tables
                .iter()
                .map(|t| t.as_ref().map_or(0, |a| a.memory_bytes()))
                .sum::<usize>()
    }
}

impl TabulatedSampler {
    /// Builds the sampler from the luminance of f(wo, wi) (no cosine).
    pub fn new(f: impl Fn(Vec3, Vec3) -> f32 + Sync) -> Self {
        use rayon::prelude::*;
        let slices: Vec<(Option<Cdf2D>, Vec<f32>)> = (0..N_THETA_O)
            .into_par_iter()
            .map(|io| Self::slice_table(&f, io))
            .collect();
        let mut tables = Vec::with_capacity(N_THETA_O);
        let mut density = Vec::with_capacity(N_THETA_O * N_THETA * N_PHI);
        for (t, d) in slices {
            tables.push(t);
            density.extend(d);
        }
        Self { tables, density }
    }

    fn slice_table(
        f: &(impl Fn(Vec3, Vec3) -> f32 + Sync),
        io: usize,
    ) -> (Option<Cdf2D>, Vec<f32>) {
        let mut density = vec![0.0f32; N_THETA * N_PHI];
        {
            let edges = [
                io as f32 / N_THETA_O as f32 * FRAC_PI_2,
                ((io + 1) as f32 / N_THETA_O as f32 * FRAC_PI_2).min(89.9f32.to_radians()),
            ];
            let mut w = vec![0.0f32; N_THETA * N_PHI];
            for it in 0..N_THETA {
                for ip in 0..N_PHI {
                    let (t0, t1, p0, p1) = cell_bounds(it, ip);
                    let solid = (t0.cos() - t1.cos()) * (p1 - p0);
                    let mut best = 0.0f32;
                    for &to in &edges {
                        let wo = dir(to, 0.0);
                        for a in 0..3 {
                            for b in 0..3 {
                                let t = t0 + (t1 - t0) * (a as f32 + 0.5) / 3.0;
                                let p = p0 + (p1 - p0) * (b as f32 + 0.5) / 3.0;
                                let wi = dir(t, p);
                                let v = f(wo, wi) * wi.z;
                                if v.is_finite() {
                                    best = best.max(v);
                                }
                            }
                        }
                    }
                    w[it * N_PHI + ip] = best * solid;
                }
            }
            let total: f64 = w.iter().map(|&x| x as f64).sum();
            if total > 0.0 {
                let (table, _) = Cdf2D::new(&w, N_PHI, N_THETA);
                for it in 0..N_THETA {
                    for ip in 0..N_PHI {
                        let (t0, t1, p0, p1) = cell_bounds(it, ip);
                        let solid = (t0.cos() - t1.cos()) * (p1 - p0) * 2.0;
                        density[it * N_PHI + ip] =
                            (w[it * N_PHI + ip] as f64 / total) as f32 / solid;
                    }
                }
                (Some(table), density)
            } else {
                (None, density)
            }
        }
    }

    /// [`TabulatedSampler::pdf`] of `LANES` pairs, lane by lane bit for bit (the angles by
    /// [`fastmath::xn`], the wrap of phi_i - phi_o by selects: the exact remainder for
    /// its range).
    pub fn pdf_xn(&self, wo: Vec3xN, wi: Vec3xN) -> f32xn {
        let s = f32xn::splat;
        let zero = s(0.0);
        let bin = |x: f32xn, n: usize| {
            x.trunc_int()
                .max(i32xn::splat(0))
                .min(i32xn::splat(n as i32 - 1))
        };
        let polar = |z: f32xn| xn::acos(z.max(s(-1.0)).min(s(1.0)));
        let io = bin(polar(wo.z) / s(FRAC_PI_2) * s(N_THETA_O as f32), N_THETA_O);
        let it = bin(polar(wi.z) / s(FRAC_PI_2) * s(N_THETA as f32), N_THETA);
        let x = xn::atan2(wi.y, wi.x) - xn::atan2(wo.y, wo.x) + s(PI);
        let x = sel(x.simd_ge(s(2.0 * PI)), x - s(2.0 * PI), x);
        let x = sel(x.simd_lt(zero), x + s(2.0 * PI), x);
        let dphi = x - s(PI);
        let ip = bin(dphi.abs() / s(PI) * s(N_PHI as f32), N_PHI);
        let cell = (io * i32xn::splat(N_THETA as i32) + it) * i32xn::splat(N_PHI as i32) + ip;
        let cos = cosine_hemisphere_pdf(wi.z);
        let mixed =
            s(COSINE_FRACTION) * cos + s(1.0 - COSINE_FRACTION) * simd::gather(&self.density, cell);
        let io = io.to_array();
        let black = simd::mask_from_bools(simd::lanes(|i| self.tables[io[i] as usize].is_none()));
        let p = sel(black, cos, mixed);
        let above = wo.z.simd_gt(zero) & wi.z.simd_gt(zero);
        sel(above, p, zero)
    }

    fn slice(wo: Vec3) -> usize {
        let theta = fastmath::acos(wo.z.clamp(-1.0, 1.0));
        ((theta / FRAC_PI_2 * N_THETA_O as f32) as usize).min(N_THETA_O - 1)
    }

    /// Samples wi for wo (local frame) from u and uc.
    pub fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<Vec3> {
        if wo.z <= 0.0 {
            return None;
        }
        let io = Self::slice(wo);
        let table = match &self.tables[io] {
            Some(t) if uc >= COSINE_FRACTION => t,
            _ => return Some(square_to_cosine_hemisphere(u)),
        };
        let uc = (uc - COSINE_FRACTION) / (1.0 - COSINE_FRACTION);
        let (ip, it, r) = table.sample(u);
        let (t0, t1, p0, p1) = cell_bounds(it, ip);
        let (c0, c1) = (t0.cos(), t1.cos());
        let ct = c0 + (c1 - c0) * r.y;
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        let mut phi = p0 + (p1 - p0) * r.x;
        if uc < 0.5 {
            phi = -phi;
        }
        let phi_o = fastmath::atan2(wo.y, wo.x);
        let (sp, cp) = fastmath::sin_cos(phi + phi_o);
        Some(Vec3::new(st * cp, st * sp, ct))
    }

    /// Density of `sample`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let io = Self::slice(wo);
        let cos = cosine_hemisphere_pdf(wi.z);
        if self.tables[io].is_none() {
            return cos;
        }
        let theta = fastmath::acos(wi.z.clamp(-1.0, 1.0));
        let it = ((theta / FRAC_PI_2 * N_THETA as f32) as usize).min(N_THETA - 1);
        let mut dphi = fastmath::atan2(wi.y, wi.x) - fastmath::atan2(wo.y, wo.x);
        dphi = (dphi + PI).rem_euclid(2.0 * PI) - PI;
        let ip = ((dphi.abs() / PI * N_PHI as f32) as usize).min(N_PHI - 1);
        COSINE_FRACTION * cos
            + (1.0 - COSINE_FRACTION) * self.density[(io * N_THETA + it) * N_PHI + ip]
    }
}
