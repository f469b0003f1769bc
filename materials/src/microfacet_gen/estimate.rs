//! Estimation of the tabulated distribution of normals from measurements (Ngan, Durand
//! and Matusik 2005, section 5, Eq. 4): p(h) = rho(k1, k2) 4 g(k1) g(k2) / (<h.n> F(k.h))
//! splatted bilinearly onto the nodes, alternating the estimates of p and of the shadowing
//! term g from g = 1; the diffuse and specular colours by the fitter's non-negative least
//! squares, the diffuse term removed in a second round, and `f0` by golden-section search
//! on the Eq. (1) error when not given.

use super::lobe::SampledMicrofacet;
use super::table::{Table, node_dir};
use crate::fit::dataset::Dataset;
use crate::lobe::Lobe;
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::Arc;

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

/// The Eq. (4) value of one measurement (diffuse removed) with the given g and the half
/// vector it estimates, or `None` below the horizon.
fn eq4_sample(
    smp: &crate::fit::dataset::Sample,
    (k1, k2): (DVec3, DVec3),
    g: &(dyn Fn(DVec3) -> f64 + Sync),
    f0: f64,
    diffuse_lum: f64,
) -> Option<(DVec3, f64)> {
    let h = (k1 + k2).normalize_or_zero();
    if h.z <= 0.0 {
        return None;
    }
    let c = k1.dot(h).clamp(0.0, 1.0);
    let fresnel = f0 + (1.0 - f0) * (1.0 - c).powi(5);
    let rho = (smp.value.iter().sum::<f64>() / 3.0 - diffuse_lum / PI).max(0.0);
    Some((h, rho * 4.0 * g(k1) * g(k2) / fresnel.max(1e-6)))
}

/// Weighted sums of values splatted linearly onto `bins` slots: (sum of w v, sum of w).
type Splats = (Vec<f64>, Vec<f64>);

/// Sums the splats of `splat` (called per measurement with the slot accumulator) over the
/// data in parallel, in a fixed chunking (the same sums for any thread count).
fn splat_all(
    data: &Dataset,
    bins: usize,
    splat: &(dyn Fn(&crate::fit::dataset::Sample, &mut Splats) + Sync),
) -> Splats {
    use rayon::prelude::*;
    let parts: Vec<Splats> = data
        .samples
        .par_chunks(8192)
        .map(|chunk| {
            let mut acc = (vec![0.0f64; bins], vec![0.0f64; bins]);
            for smp in chunk {
                splat(smp, &mut acc);
            }
            acc
        })
        .collect();
    parts
        .into_iter()
        .fold((vec![0.0; bins], vec![0.0; bins]), |mut a, b| {
            for k in 0..bins {
                a.0[k] += b.0[k];
                a.1[k] += b.1[k];
            }
            a
        })
}

/// Fills the `None` entries of `p` that `inside` admits from their filled neighbours
/// (`neighbours` of an index), ring by ring.
fn fill_from_neighbours(
    p: &mut [Option<f64>],
    inside: &dyn Fn(usize) -> bool,
    neighbours: &dyn Fn(usize) -> Vec<usize>,
) {
    for _ in 0..2 * p.len().max(1) {
        let fills: Vec<(usize, f64)> = (0..p.len())
            .filter(|&k| inside(k) && p[k].is_none())
            .filter_map(|k| {
                let near: Vec<f64> = neighbours(k).into_iter().filter_map(|j| p[j]).collect();
                (!near.is_empty()).then(|| (k, near.iter().sum::<f64>() / near.len() as f64))
            })
            .collect();
        if fills.is_empty() {
            return;
        }
        for (k, v) in fills {
            p[k] = Some(v);
        }
    }
}

/// One estimate of p from the data (diffuse removed), with the given g, by Eq. (4).
///
/// Anisotropic data splat each measurement's value bilinearly onto the nodes around its
/// half vector. Isotropic data hold one azimuth of each configuration, and their p is
/// symmetric about the normal: their values are splatted onto a radial profile (linear in
/// the projected radius |h_xy|, `n` slots from 0 to 1), which every node then reads at its
/// radius. (Spreading the measurements over a few rotations instead leaves a polygon of
/// their count in the table.)
fn estimate_p(
    data: &Dataset,
    n: usize,
    g: &(dyn Fn(DVec3) -> f64 + Sync),
    f0: f64,
    diffuse_lum: f64,
) -> Vec<f64> {
    let value = |smp: &crate::fit::dataset::Sample| {
        let pair = (smp.wi.as_dvec3(), smp.wo.as_dvec3());
        eq4_sample(smp, pair, g, f0, diffuse_lum)
    };
    match data.anisotropic {
        false => radial_estimate(data, n, &value),
        true => table_estimate(data, n, &value),
    }
}

/// A measurement's half vector and its Eq. (4) value of p, if it has one.
type PointValue<'a> = dyn Fn(&crate::fit::dataset::Sample) -> Option<(DVec3, f64)> + Sync + 'a;

/// Isotropic data: the values splatted onto a radial profile (linear in |h_xy|, `n` slots
/// from 0 to 1, empty slots filled from their neighbours), read by every node of the
/// `n` x `n` table at its radius.
fn radial_estimate(data: &Dataset, n: usize, value: &PointValue<'_>) -> Vec<f64> {
    let s = (n - 1) as f64 / 2.0;
    let last = (n - 1) as f64;
    let (acc, wsum) = splat_all(data, n, &|smp, (acc, wsum)| {
        if let Some((h, v)) = value(smp) {
            let t = (h.x.hypot(h.y) * last).min(last);
            let i = (t as usize).min(n - 2);
            let f = t - i as f64;
            for (k, w) in [(i, 1.0 - f), (i + 1, f)] {
                acc[k] += w * v;
                wsum[k] += w;
            }
        }
    });
    let mut radial: Vec<Option<f64>> = (0..n)
        .map(|k| (wsum[k] > 1e-9).then(|| acc[k] / wsum[k]))
        .collect();
    let near = |k: usize| {
        [k.wrapping_sub(1), k + 1]
            .into_iter()
            .filter(|&j| j < n)
            .collect()
    };
    fill_from_neighbours(&mut radial, &|_| true, &near);
    let radial: Vec<f64> = radial.into_iter().map(|v| v.unwrap_or(0.0)).collect();
    (0..n * n)
        .map(|k| {
            let (x, y) = (-1.0 + (k % n) as f64 / s, -1.0 + (k / n) as f64 / s);
            let t = (x.hypot(y) * last).min(last);
            let i = (t as usize).min(n - 2);
            let f = t - i as f64;
            match node_dir(n, k % n, k / n) {
                Some(_) => radial[i] * (1.0 - f) + radial[i + 1] * f,
                None => 0.0,
            }
        })
        .collect()
}

/// Anisotropic data: each value splatted bilinearly onto the `n` x `n` nodes around its
/// half vector's projection, empty nodes inside the disc filled from their neighbours.
fn table_estimate(data: &Dataset, n: usize, value: &PointValue<'_>) -> Vec<f64> {
    let s = (n - 1) as f64 / 2.0;
    let inside = |k: usize| node_dir(n, k % n, k / n).is_some();
    let (acc, wsum) = splat_all(data, n * n, &|smp, (acc, wsum)| {
        if let Some((h, v)) = value(smp) {
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
    });
    let mut p: Vec<Option<f64>> = (0..n * n)
        .map(|k| (inside(k) && wsum[k] > 1e-9).then(|| acc[k] / wsum[k]))
        .collect();
    let near = |k: usize| {
        let (x, y) = ((k % n) as i64, (k / n) as i64);
        [(-1, 0), (1, 0), (0, -1), (0, 1)]
            .into_iter()
            .map(|(dx, dy)| (x + dx, y + dy))
            .filter(|&(a, b)| a >= 0 && b >= 0 && a < n as i64 && b < n as i64)
            .map(|(a, b)| b as usize * n + a as usize)
            .collect()
    };
    fill_from_neighbours(&mut p, &inside, &near);
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
            Some(t) => estimate_p(data, n, &|k| t.g(k.into()), f0, diffuse_lum),
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
