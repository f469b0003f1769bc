//! The metrics a fit can minimize (`lobe fit --metric`), and for each the solve of the
//! colours that keeps the shape optimizer seeing only the lobe parameters.
//!
//! With R the measured value, M = d / pi + sum_k s_k lobe_k(p) the model (colours d, s_k
//! per channel), w = sin(theta_i) sin(theta_o) the bin weight and c = cos(theta_i), over
//! the bins and the three channels:
//!
//! - `eq1`, Ngan et al. 2005 Eq. (1): E = sqrt( sum w [(R - M) c]^2 / (3 sum w) ). Linear
//!   in the colours: non-negative least squares ([`super::linear`]) solves them exactly.
//!   `ngan2005` is an alias.
//! - `log`: E = sqrt( sum w [g(R c) - g(M c)]^2 / (3 sum w) ) with g(x) = ln(1 + x), the
//!   compression of the cosine-weighted BRDF of Löw, Kronander, Ynnerman and Unger 2012
//!   ("BRDF models for accurate and efficient rendering of glossy surfaces", ACM TOG 31(1),
//!   section 5), which keeps the specular peak from outweighing the rest of the lobe.
//! - `cube-root`: the same with g(x) = x^(1/3), the cube-root compression that Bieron and
//!   Peers 2020 ("An adaptive BRDF fitting metric", CGF 39(4)) discuss among fitting
//!   metrics (a perceptual lightness-like response to the reflected radiance).
//!
//!   g is extended to negative values as an odd function (measured values can dip below
//!   zero); g' is evaluated at max(|m|, 1e-9 max |R c|) so that the cube root's infinite
//!   slope at zero stays finite.
//!
//!   These two are not linear in the colours. Per channel the colours x >= 0 minimize
//!   Phi(x) = sum w [g(r) - g(a.x)]^2 (r = R c, a = the basis values times c) by
//!   Gauss-Newton on non-negative least squares: from the `eq1` solution, each step solves
//!   the NNLS problem linearized at the current prediction m = a.x, i.e. targets
//!   m + (g(r) - g(m)) / g'(m) with weights w g'(m)^2 (a reweighted least squares), then
//!   backtracks along the step until Phi decreases. A fixed point satisfies the
//!   Karush-Kuhn-Tucker conditions of Phi (the linearized gradient at x is Phi's gradient),
//!   so it stops at the constrained optimum, typically in 3 to 8 steps.
//! - `image`: the RMS difference between renders of a sphere under environment maps of the
//!   fit and of the measured material ([`super::image::SphereImages`]): the render is
//!   linear in the colours, so they come from NNLS on the pixels.
//!
//! Whatever the metric, a fit's report keeps its Eq. (1) error (so fits are comparable)
//! beside the value of the metric it minimized.

use super::dataset::Dataset;
use super::image::SphereImages;
use super::linear::Gram;
use crate::lobe::Lobe;
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_1_PI;
use std::sync::Arc;

/// The metric a fit minimizes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Metric {
    /// Ngan et al. 2005 Eq. (1), the study's metric.
    #[default]
    #[serde(rename = "eq1")]
    Eq1,
    /// Eq. (1) on ln(1 + f cos), Löw et al. 2012.
    #[serde(rename = "log")]
    Log,
    /// Eq. (1) on (f cos)^(1/3), as discussed by Bieron and Peers 2020.
    #[serde(rename = "cube-root")]
    CubeRoot,
    /// Image error of renders of a sphere under environment maps.
    #[serde(rename = "image")]
    Image,
}

impl Metric {
    pub const ALL: [Metric; 4] = [Metric::Eq1, Metric::Log, Metric::CubeRoot, Metric::Image];

    /// The name `lobe fit --metric` and reports use.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Eq1 => "eq1",
            Metric::Log => "log",
            Metric::CubeRoot => "cube-root",
            Metric::Image => "image",
        }
    }

    /// The metric of a name (or of `ngan2005`, an alias of `eq1`).
    pub fn parse(s: &str) -> Result<Metric, String> {
        if s == "ngan2005" {
            return Ok(Metric::Eq1);
        }
        Metric::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown metric \"{s}\"; expected one of: eq1 (alias ngan2005), log, cube-root, image"
                )
            })
    }

    /// The compression of a pointwise compressed metric.
    pub fn compression(self) -> Option<Compression> {
        match self {
            Metric::Log => Some(Compression::Log),
            Metric::CubeRoot => Some(Compression::CubeRoot),
            Metric::Eq1 | Metric::Image => None,
        }
    }
}

impl std::fmt::Display for Metric {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What one fit minimizes: a metric over the bins, or the image metric with its renders.
#[derive(Clone, Copy, Debug, Default)]
pub enum Objective<'a> {
    #[default]
    Eq1,
    Compressed(Compression),
    Image(&'a SphereImages),
}

impl<'a> Objective<'a> {
    /// The objective of a metric over the bins; None for `image`, which needs renders.
    pub fn pointwise(m: Metric) -> Option<Objective<'a>> {
        match m {
            Metric::Eq1 => Some(Objective::Eq1),
            Metric::Image => None,
            _ => m.compression().map(Objective::Compressed),
        }
    }

    pub fn metric(&self) -> Metric {
        match self {
            Objective::Eq1 => Metric::Eq1,
            Objective::Compressed(Compression::Log) => Metric::Log,
            Objective::Compressed(Compression::CubeRoot) => Metric::CubeRoot,
            Objective::Image(_) => Metric::Image,
        }
    }
}

/// The compression g of a compressed metric.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    /// g(x) = ln(1 + x).
    Log,
    /// g(x) = x^(1/3).
    CubeRoot,
}

impl Compression {
    /// g, odd-extended to negative x.
    #[inline]
    pub fn g(self, x: f64) -> f64 {
        let a = x.abs();
        let v = match self {
            Compression::Log => a.ln_1p(),
            Compression::CubeRoot => a.cbrt(),
        };
        v.copysign(x)
    }

    /// (g(x), g'(max(|x|, floor))), sharing the transcendental.
    #[inline]
    pub fn value_slope(self, x: f64, floor: f64) -> (f64, f64) {
        let a = x.abs();
        match self {
            Compression::Log => (a.ln_1p().copysign(x), 1.0 / (1.0 + a.max(floor))),
            Compression::CubeRoot => {
                let s = a.cbrt();
                let t = if a >= floor { s } else { floor.cbrt() };
                (s.copysign(x), 1.0 / (3.0 * t * t))
            }
        }
    }

    /// g' at |x| (positive; infinite at 0 for the cube root).
    #[inline]
    pub fn slope(self, x: f64) -> f64 {
        let a = x.abs();
        match self {
            Compression::Log => 1.0 / (1.0 + a),
            Compression::CubeRoot => 1.0 / (3.0 * a.cbrt() * a.cbrt()),
        }
    }
}

/// The colour basis of every bin, cosine included: `a[i][c][k]` is basis k (the diffuse
/// 1/pi, then each lobe at unit colour) of channel c times cos(theta_i), `r[i][c]` the
/// measured value times cos(theta_i).
struct Basis {
    n: usize,
    a: Vec<[[f64; 3]; 3]>,
    r: Vec<[f64; 3]>,
    w: Vec<f64>,
}

impl Basis {
    fn new(data: &Dataset, lobes: &[Arc<dyn Lobe>]) -> Self {
        use rayon::prelude::*;
        let n = 1 + lobes.len();
        let per_chunk: Vec<Vec<[[f64; 3]; 3]>> = data
            .samples
            .par_chunks(4096)
            .map(|chunk| {
                let pairs: Vec<_> = chunk
                    .iter()
                    .map(|s| (s.wo.as_dvec3(), s.wi.as_dvec3()))
                    .collect();
                let mut a = vec![[[0.0; 3]; 3]; chunk.len()];
                for (s, ai) in chunk.iter().zip(&mut a) {
                    let c = s.cos2.sqrt();
                    for ch in ai.iter_mut() {
                        ch[0] = FRAC_1_PI * c;
                    }
                }
                let mut buf = vec![[0.0; 3]; chunk.len()];
                for (k, l) in lobes.iter().enumerate() {
                    l.eval_f64_many(&pairs, &mut buf);
                    for ((ai, b), s) in a.iter_mut().zip(&buf).zip(chunk) {
                        let c = s.cos2.sqrt();
                        for ch in 0..3 {
                            ai[ch][k + 1] = if b[ch].is_finite() { b[ch] * c } else { 0.0 };
                        }
                    }
                }
                a
            })
            .collect();
        let r = data
            .samples
            .iter()
            .map(|s| {
                let c = s.cos2.sqrt();
                [s.value[0] * c, s.value[1] * c, s.value[2] * c]
            })
            .collect();
        Self {
            n,
            a: per_chunk.into_iter().flatten().collect(),
            r,
            w: data.samples.iter().map(|s| s.weight).collect(),
        }
    }

    fn predict(&self, i: usize, c: usize, x: &[f64; 3]) -> f64 {
        (0..self.n).map(|k| self.a[i][c][k] * x[k]).sum()
    }

    /// Phi(x) = sum w [g(r) - g(a.x)]^2 of channel c, with `gr` = g(r).
    fn phi(&self, c: usize, g: Compression, gr: &[f64], x: &[f64; 3]) -> f64 {
        ordered_sum(
            self.r.len(),
            |acc: &mut f64, i| {
                let d = gr[i] - g.g(self.predict(i, c, x));
                *acc += self.w[i] * d * d;
            },
            0.0,
            |a, b| a + b,
        )
    }

    /// The normal equations of Eq. (1) of channel c.
    fn eq1_gram(&self, c: usize) -> Gram {
        let n = self.n;
        ordered_sum(
            self.r.len(),
            |gram: &mut Gram, i| gram.add(&self.a[i][c][..n], self.r[i][c], self.w[i]),
            Gram::new(n),
            |a, b| a.merge(&b),
        )
    }

    /// In one pass at colours x of channel c: Phi(x), and the normal equations of Phi
    /// linearized at the prediction m = a.x (targets m + (g(r) - g(m)) / g'(m), weights
    /// w g'(m)^2, with g' taken at max(|m|, floor)).
    fn linearize(
        &self,
        c: usize,
        g: Compression,
        (gr, floor): (&[f64], f64),
        x: &[f64; 3],
    ) -> (f64, Gram) {
        let n = self.n;
        ordered_sum(
            self.r.len(),
            |(phi, gram): &mut (f64, Gram), i| {
                let m = self.predict(i, c, x);
                let (gm, slope) = g.value_slope(m, floor);
                let d = gr[i] - gm;
                gram.add(&self.a[i][c][..n], m + d / slope, self.w[i] * slope * slope);
                *phi += self.w[i] * d * d;
            },
            (0.0, Gram::new(n)),
            |a, b| (a.0 + b.0, a.1.merge(&b.1)),
        )
    }

    /// The non-negative colours of channel c minimizing Phi (Gauss-Newton on NNLS from the
    /// Eq. (1) solution, backtracking), and Phi there.
    fn channel_optimum(&self, c: usize, g: Compression) -> ([f64; 3], f64) {
        let gr: Vec<f64> = self.r.iter().map(|r| g.g(r[c])).collect();
        let floor = 1e-9 * self.r.iter().map(|r| r[c].abs()).fold(0.0, f64::max) + 1e-300;
        let mut x = self.eq1_gram(c).solve_nonnegative().0;
        let (mut phi, mut gram) = self.linearize(c, g, (&gr, floor), &x);
        for _ in 0..GAUSS_NEWTON_STEPS {
            let target = gram.solve_nonnegative().0;
            let mut t = 1.0;
            let mut next = None;
            while t > 1e-6 {
                let xt: [f64; 3] = std::array::from_fn(|k| x[k] + t * (target[k] - x[k]));
                let (p, gt) = self.linearize(c, g, (&gr, floor), &xt);
                if p < phi {
                    next = Some((xt, p, gt));
                    break;
                }
                t *= 0.5;
            }
            let Some((xt, p, gt)) = next else { break };
            let size = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let step = (0..3).fold(0.0f64, |m, k| m.max((xt[k] - x[k]).abs()));
            let converged = phi - p <= 1e-9 * phi || step <= 1e-9 * size;
            (x, phi, gram) = (xt, p, gt);
            if converged {
                break;
            }
        }
        (x, phi)
    }
}

/// The accumulation over i < n by `add_term` (from `zero`), in parallel over fixed chunks
/// of 4096 merged in order: the same bits whatever the thread count and scheduling.
pub fn ordered_sum<T: Send + Sync + Clone>(
    n: usize,
    add_term: impl Fn(&mut T, usize) + Sync,
    zero: T,
    merge: impl Fn(T, T) -> T,
) -> T {
    use rayon::prelude::*;
    const CHUNK: usize = 4096;
    let parts: Vec<T> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|k| {
            let mut acc = zero.clone();
            for i in k * CHUNK..((k + 1) * CHUNK).min(n) {
                add_term(&mut acc, i);
            }
            acc
        })
        .collect();
    parts.into_iter().fold(zero, merge)
}

/// Gauss-Newton steps allowed per channel of a compressed metric's colour solve.
pub const GAUSS_NEWTON_STEPS: usize = 30;

/// For fixed lobes (at most two), the non-negative colours minimizing the compressed
/// metric `g` on `data`, and that metric: (error, [diffuse, specular of each lobe]).
pub fn compressed_colours(
    data: &Dataset,
    lobes: &[Arc<dyn Lobe>],
    g: Compression,
    total_weight: f64,
) -> (f64, [[f64; 3]; 3]) {
    assert!(lobes.len() <= 2, "at most two lobes");
    let basis = Basis::new(data, lobes);
    let mut colours = [[0.0f64; 3]; 3];
    let mut sum = 0.0;
    for c in 0..3 {
        let (x, phi) = basis.channel_optimum(c, g);
        sum += phi;
        for (colour, v) in colours.iter_mut().zip(x) {
            colour[c] = v;
        }
    }
    ((sum / (3.0 * total_weight)).sqrt(), colours)
}

/// The compressed metric `g` of given colours ([diffuse, specular of each lobe]) and lobes.
pub fn compressed_error(
    data: &Dataset,
    lobes: &[Arc<dyn Lobe>],
    g: Compression,
    colours: &[[f64; 3]; 3],
) -> f64 {
    let basis = Basis::new(data, lobes);
    let sum: f64 = (0..3)
        .map(|c| {
            let gr: Vec<f64> = basis.r.iter().map(|r| g.g(r[c])).collect();
            basis.phi(c, g, &gr, &std::array::from_fn(|k| colours[k][c]))
        })
        .sum();
    (sum / (3.0 * data.total_weight().max(1e-300))).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_ngan2005_is_eq1() {
        for m in Metric::ALL {
            assert_eq!(Metric::parse(m.name()), Ok(m));
            assert_eq!(serde_json::to_value(m).unwrap(), m.name());
        }
        assert_eq!(Metric::parse("ngan2005"), Ok(Metric::Eq1));
        let e = Metric::parse("l2").unwrap_err();
        assert!(e.contains("\"l2\"") && e.contains("cube-root"), "{e}");
    }

    #[test]
    fn compressions_are_odd_with_the_right_slope() {
        for g in [Compression::Log, Compression::CubeRoot] {
            for x in [1e-3, 0.2, 3.0, 250.0] {
                assert_eq!(g.g(-x), -g.g(x));
                let h = x * 1e-6;
                let numeric = (g.g(x + h) - g.g(x - h)) / (2.0 * h);
                assert!((numeric / g.slope(x) - 1.0).abs() < 1e-6, "{g:?} at {x}");
            }
        }
    }
}
