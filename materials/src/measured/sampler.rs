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

use crate::fastmath;
use crate::math::{Num, V3, abs, acos, atan2, gt, le, lt, maximum, minimum, select};
use crate::sampling::cdf::Cdf2D;
use crate::sampling::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
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

    /// [`TabulatedSampler::pdf`] written once over [`Num`] (one pair, or lanes of pairs):
    /// the mixture of the cosine lobe and the slice's tabulated density (the cosine lobe
    /// alone where the slice has no table), zero below the surface.
    #[inline]
    pub fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let s = T::of;
        let zero = s(0.0);
        let bin =
            |x: T, n: usize| T::int_min(T::int_max(x.trunc_int(), T::int(0)), T::int(n as i32 - 1));
        let polar = |z: T| acos(minimum(maximum(z, s(-1.0)), s(1.0)));
        let io = bin(
            polar(wo.z) / s(FRAC_PI_2 as f64) * s(N_THETA_O as f64),
            N_THETA_O,
        );
        let it = bin(
            polar(wi.z) / s(FRAC_PI_2 as f64) * s(N_THETA as f64),
            N_THETA,
        );
        let (pi, two_pi) = (s(PI as f64), s((2.0 * PI) as f64));
        let x = atan2(wi.y, wi.x) - atan2(wo.y, wo.x) + pi;
        let x = select(le(two_pi, x), x - two_pi, x);
        let x = select(lt(x, zero), x + two_pi, x);
        let dphi = x - pi;
        let ip = bin(abs(dphi) / pi * s(N_PHI as f64), N_PHI);
        let cell = (io * T::int(N_THETA as i32) + it) * T::int(N_PHI as i32) + ip;
        let cos = cosine_hemisphere_pdf(wi.z);
        let fraction = s(COSINE_FRACTION as f64);
        let mixed =
            fraction * cos + s((1.0 - COSINE_FRACTION) as f64) * T::gather(&self.density, cell);
        let [tabulated] = T::gather_by(io, |k| [self.tables[k].is_some() as u8 as f32]);
        let p = select(gt(tabulated, zero), mixed, cos);
        select(gt(wo.z, zero) & gt(wi.z, zero), p, zero)
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

    /// Density of `sample` (solid angle of wi), zero below the surface.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        self.density(V3::from(wo), V3::from(wi))
    }
}
