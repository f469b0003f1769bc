//! The study's material: `M = diffuse_rgb * Lambert + sum_k specular_rgb_k * lobe_k(p)`
//! (Ngan et al. 2005, section 3.1, generalized to N lobes as in section 4.2).
//!
//! Sampling picks a component in proportion to its estimated albedo for the current `wo`
//! (the luminance of its colour times the lobe's directional albedo, tabulated over
//! cos(theta_o) when the material is built), samples it, and reports the mixture density
//! (one-sample MIS with the balance heuristic), so every component's sampler helps.

use crate::bsdf::{Bsdf, BsdfSample, BsdfSamplesMut, Flags, Rgb};
use crate::columns::{Vec2Cols, Vec3Cols, Vec3ColsMut};
use crate::lobe::Lobe;
use crate::math::{Num, all, clamp, gt, is_finite, le, lt, maximum, select};
use crate::sampling::warp::{
    cosine_hemisphere, cosine_hemisphere_pdf, square_to_cosine_hemisphere,
};
use crate::simd::{self, RgbxN, Vec3xN, f32xn, i32xn, sel};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// Bins of the directional-albedo table over cos(theta_o).
const ALBEDO_BINS: usize = 32;

#[derive(Debug, Clone)]
pub struct Composite {
    name: &'static str,
    diffuse: Rgb,
    lobes: Vec<(Rgb, Arc<dyn Lobe>)>,
    /// Per lobe: luminance of its colour times its directional albedo, per cos(theta_o)
    /// bin, each raised to at least 1e-4 of the lobe's largest (so that every lobe is
    /// sampled a little, even where its albedo estimate is tiny).
    lobe_weights: Vec<[f32; ALBEDO_BINS]>,
    flags: Flags,
}

/// Directional albedo of a lobe, int lobe(wo, wi) cos(theta_i) dwi, for `wo` at each
/// bin centre: deterministic stratified estimate with a 50/50 mixture of cosine and lobe
/// sampling (balance heuristic), so it is unbiased even where the lobe sampler fails.
pub fn albedo_table(lobe: &dyn Lobe, n: usize) -> [f32; ALBEDO_BINS] {
    let mut out = [0.0f32; ALBEDO_BINS];
    for (b, slot) in out.iter_mut().enumerate() {
        let cos_o = (b as f32 + 0.5) / ALBEDO_BINS as f32;
        let wo = Vec3::new((1.0 - cos_o * cos_o).max(0.0).sqrt(), 0.0, cos_o);
        *slot = directional_albedo(lobe, wo, n) as f32;
    }
    out
}

/// Directional albedo of a lobe for one `wo`, from n x n stratified samples per strategy.
pub fn directional_albedo(lobe: &dyn Lobe, wo: Vec3, n: usize) -> f64 {
    let mut acc = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let uc = ((i * n + j) as f32 * 0.618_034).fract();
            for wi in [Some(square_to_cosine_hemisphere(u)), lobe.sample(wo, u, uc)]
                .into_iter()
                .flatten()
            {
                if wi.z <= 0.0 {
                    continue;
                }
                let pdf = 0.5 * cosine_hemisphere_pdf(wi.z) + 0.5 * lobe.pdf(wo, wi);
                if pdf > 0.0 {
                    acc += (lobe.eval(wo, wi).luminance() * wi.z / pdf) as f64;
                }
            }
        }
    }
    // 2 n^2 stratified draws from the 50/50 mixture (a failed lobe sample is a draw that
    // contributes zero).
    acc / (2 * n * n) as f64
}

impl Composite {
    pub fn new(name: &'static str, diffuse: Rgb, lobes: Vec<(Rgb, Arc<dyn Lobe>)>) -> Self {
        let lobe_weights = lobes
            .iter()
            .map(|(c, l)| {
                let mut t = albedo_table(l.as_ref(), 16);
                let lum = c.luminance().max(0.0);
                for v in &mut t {
                    *v = if v.is_finite() {
                        (*v).max(0.0) * lum
                    } else {
                        0.0
                    };
                }
                // A floor keeps every lobe sampled a little, even where its albedo
                // estimate is tiny.
                let floor = 1e-4 * t.iter().fold(0.0f32, |a, &b| a.max(b));
                t.map(|v| v.max(floor))
            })
            .collect();
        // The mixture keeps a property only if every lobe has it; it is energy-bounded when
        // every lobe is (albedo <= 1 per unit colour) and the colours sum to at most 1 in
        // every channel.
        let all = |f: Flags| lobes.iter().all(|(_, l)| l.flags().contains(f));
        let colour_sum = lobes.iter().fold(diffuse, |a, (c, _)| a + *c);
        let mut flags = Flags::NONE;
        if all(Flags::ISOTROPIC) {
            flags = flags | Flags::ISOTROPIC;
        }
        if all(Flags::RECIPROCAL) {
            flags = flags | Flags::RECIPROCAL;
        }
        if all(Flags::ENERGY_BOUNDED) && colour_sum.max_component() <= 1.0 {
            flags = flags | Flags::ENERGY_BOUNDED;
        }
        if diffuse.max_component() > 0.0 {
            flags = flags | Flags::DIFFUSE;
        }
        if !lobes.is_empty() {
            flags = flags | Flags::GLOSSY;
        }
        Self {
            name,
            diffuse,
            lobes,
            lobe_weights,
            flags,
        }
    }

    pub fn diffuse(&self) -> Rgb {
        self.diffuse
    }

    pub fn lobes(&self) -> &[(Rgb, Arc<dyn Lobe>)] {
        &self.lobes
    }

    /// Probabilities of choosing the diffuse component and each lobe for `wo`.
    #[inline]
    fn weights(&self, wo: Vec3, out: &mut [f32]) -> f32 {
        let bin = ((wo.z * ALBEDO_BINS as f32) as usize).min(ALBEDO_BINS - 1);
        out[0] = self.diffuse.luminance().max(0.0);
        let mut total = out[0];
        for (k, t) in self.lobe_weights.iter().enumerate() {
            out[k + 1] = t[bin];
            total += t[bin];
        }
        total
    }
}

/// Most materials have few lobes: weights live on the stack (the batched calls take the
/// one-at-a-time path beyond this many).
const MAX_INLINE: usize = 8;
/// Queries [`Bsdf::sample_many`] handles together: the queries of one block that chose
/// the same lobe share its lane calls.
const SAMPLE_BLOCK: usize = 256;

/// The component of a query that chose none (its weights sum to zero).
const NO_COMPONENT: usize = usize::MAX;

/// The component weights of `LANES` queries, `w[k]` lane by lane, and their sums.
struct LaneWeights {
    w: [f32xn; MAX_INLINE + 1],
    total: f32xn,
}

/// The directions of a block's queries as x, y and z columns (on the stack), and which
/// queries drew one.
struct BlockDirections {
    xyz: [[f32; SAMPLE_BLOCK]; 3],
    drawn: [bool; SAMPLE_BLOCK],
}

impl BlockDirections {
    fn new() -> Self {
        Self {
            xyz: [[0.0; SAMPLE_BLOCK]; 3],
            drawn: [false; SAMPLE_BLOCK],
        }
    }

    #[inline(always)]
    fn get(&self, k: usize) -> Vec3 {
        Vec3::new(self.xyz[0][k], self.xyz[1][k], self.xyz[2][k])
    }

    #[inline(always)]
    fn set(&mut self, k: usize, v: Vec3) {
        (self.xyz[0][k], self.xyz[1][k], self.xyz[2][k]) = (v.x, v.y, v.z);
    }

    /// The first `n` directions.
    fn cols(&self, n: usize) -> Vec3Cols<'_> {
        let [x, y, z] = &self.xyz;
        Vec3Cols::new(&x[..n], &y[..n], &z[..n])
    }

    /// The first `n` directions and flags, to be written.
    fn cols_mut(&mut self, n: usize) -> (Vec3ColsMut<'_>, &mut [bool]) {
        let [x, y, z] = &mut self.xyz;
        let cols = Vec3ColsMut::new(&mut x[..n], &mut y[..n], &mut z[..n]);
        (cols, &mut self.drawn[..n])
    }
}

impl Bsdf for Composite {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        Rgb::from(self.mixed_value(|k| self.lobes[k].1.eval(wo, wi).to_array()))
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        self.with_weights(wo, |w, total| self.sample_with(wo, u, uc, w, total))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.with_weights(wo, |w, total| Some(self.mixture_pdf(wo, wi, w, total)))
            .unwrap_or(0.0)
    }

    /// The pairs above the surface a lane vector at a time: every lobe's
    /// [`Lobe::eval_pdf_xn`] once per `LANES` pairs ([`Composite::mix_lanes`]).
    fn eval_pdf_many(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb], pdf: &mut [f32]) {
        self.evaluate(wo, wi, f, Some(pdf));
    }

    /// The values of [`Bsdf::eval_pdf_many`] alone: every lobe's [`Lobe::eval_xn`] once per
    /// `LANES` pairs above the surface, mixed as there.
    fn eval_many(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb]) {
        self.evaluate(wo, wi, f, None);
    }

    /// Components chosen and sampled query by query, the mixture density and the value of
    /// `LANES` sampled directions at a time ([`Composite::mix_lanes`]).
    fn sample_many(&self, wo: Vec3Cols, u: Vec2Cols, uc: &[f32], mut out: BsdfSamplesMut) {
        let n = out.len();
        assert!(wo.len() == n && u.len() == n && uc.len() == n);
        if self.lobes.len() > MAX_INLINE {
            for (k, &uc) in uc.iter().enumerate() {
                out.set(k, self.sample(wo.get(k), u.get(k), uc));
            }
            return;
        }
        out.clear();
        for first in (0..n).step_by(SAMPLE_BLOCK) {
            let r = first..(first + SAMPLE_BLOCK).min(n);
            self.sample_block(
                wo.slice(r.clone()),
                u.slice(r.clone()),
                &uc[r.clone()],
                out.slice(r),
            );
        }
    }

    fn flags(&self) -> Flags {
        self.flags
    }

    fn name(&self) -> &str {
        self.name
    }
    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self)
            + self
                .lobes
                .iter()
                .map(|(_, l)| l.memory_bytes())
                .sum::<usize>()
            + self.lobe_weights.len() * std::mem::size_of::<[f32; ALBEDO_BINS]>()
    }
}

impl Composite {
    /// [`Bsdf::eval_pdf_many`] (or, without `pdf`, its values alone): the pairs above the
    /// surface a lane vector at a time, every lobe once per `LANES` pairs.
    #[inline(always)]
    fn evaluate(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb], mut pdf: Option<&mut [f32]>) {
        let n = f.len();
        assert!(wo.len() == n && wi.len() == n);
        assert!(pdf.as_ref().is_none_or(|p| p.len() == n));
        if self.lobes.len() > MAX_INLINE {
            for k in 0..n {
                f[k] = self.eval(wo.get(k), wi.get(k));
                if let Some(pdf) = pdf.as_deref_mut() {
                    pdf[k] = self.pdf(wo.get(k), wi.get(k));
                }
            }
            return;
        }
        f.fill(Rgb::ZERO);
        if let Some(pdf) = pdf.as_deref_mut() {
            pdf.fill(0.0);
        }
        pairs_above(wo, wi, |idx, o, i| {
            let v = match pdf.as_deref_mut() {
                Some(pdf) => {
                    let w = self.lane_weights(o.z);
                    let (v, p) = self.mix_lanes(o, i, &w);
                    // A pair whose components are all black has density 0.
                    let zero = f32xn::splat(0.0);
                    let p = sel(w.total.simd_gt(zero), p, zero).to_array();
                    for (lane, &k) in idx.iter().enumerate() {
                        pdf[k] = p[lane];
                    }
                    v
                }
                None => {
                    let [r, g, b] = self.mixed_value(|k| {
                        let v = self.lobes[k].1.eval_xn(o, i);
                        [v.r, v.g, v.b]
                    });
                    RgbxN::new(r, g, b)
                }
            };
            let v = v.to_array();
            for (lane, &k) in idx.iter().enumerate() {
                f[k] = v[lane];
            }
        });
    }

    /// Runs `f` with the component probabilities for `wo` (on the stack for up to
    /// [`MAX_INLINE`] lobes); None when every component is black.
    fn with_weights<R>(&self, wo: Vec3, f: impl FnOnce(&[f32], f32) -> Option<R>) -> Option<R> {
        let mut buf = [0.0f32; MAX_INLINE + 1];
        let mut heap;
        let w: &mut [f32] = if self.lobes.len() <= MAX_INLINE {
            &mut buf[..self.lobes.len() + 1]
        } else {
            heap = vec![0.0f32; self.lobes.len() + 1];
            &mut heap
        };
        let total = self.weights(wo, w);
        if !(total > 0.0) {
            return None;
        }
        f(w, total)
    }

    fn sample_with(&self, wo: Vec3, u: Vec2, uc: f32, w: &[f32], total: f32) -> Option<BsdfSample> {
        let wi = self.choose_and_sample(wo, u, uc, w, total)?;
        BsdfSample::finish(
            wi,
            || self.mixture_pdf(wo, wi, w, total),
            || self.eval(wo, wi),
        )
    }

    /// Chooses a component with `uc` in proportion to the weights `w` (sum `total`) and
    /// samples it.
    fn choose_and_sample(&self, wo: Vec3, u: Vec2, uc: f32, w: &[f32], total: f32) -> Option<Vec3> {
        let (chosen, uc_rest) = Self::choose(uc, w, total);
        let chosen = chosen as usize;
        if chosen == 0 {
            Some(square_to_cosine_hemisphere(u))
        } else {
            self.lobes[chosen - 1].1.sample(wo, u, uc_rest)
        }
    }

    /// [`Bsdf::sample_many`] of at most [`SAMPLE_BLOCK`] queries (`out` all "no sample"), each
    /// bit for bit [`Bsdf::sample`]: every query above the surface chooses its component
    /// as the scalar call does (weights a lane vector at a time), then the queries that chose
    /// each lobe are sampled together, a lane vector at a time ([`Lobe::sample_xn`]), so that no
    /// lane samples a lobe its query did not choose; last, the value and the mixture
    /// density of every drawn direction, a lane vector at a time. Queries whose weights sum to
    /// zero stay "no sample".
    fn sample_block(&self, wo: Vec3Cols, u: Vec2Cols, uc: &[f32], mut out: BsdfSamplesMut) {
        let m = wo.len();
        debug_assert!(m <= SAMPLE_BLOCK);
        let mut choice = [(NO_COMPONENT, 0.0f32); SAMPLE_BLOCK];
        let mut wi = BlockDirections::new();
        self.choose_components(wo, u, uc, &mut choice[..m], &mut wi);
        self.sample_chosen_lobes(wo, u, &choice[..m], &mut wi);
        let (drawn, wi) = (&wi.drawn, wi.cols(m));
        simd::chunks_where(
            m,
            |k| drawn[k],
            |idx| {
                let (o, d) = (wo.lanes_of(idx), wi.lanes_of(idx));
                let w = self.lane_weights(o.z);
                let (v, p) = self.mix_lanes(o, d, &w);
                let (weight, keep) = BsdfSample::weight_where(d.z, p, [v.r, v.g, v.b]);
                let keep = simd::mask_bits(keep);
                // Each sample from the lanes' floats (copies of 12-byte records through the
                // stack stall on store forwarding).
                let [wr, wg, wb] = weight.map(|c| c.to_array());
                let [dx, dy, dz] = [d.x, d.y, d.z].map(|c| c.to_array());
                let p = p.to_array();
                for (lane, &k) in idx.iter().enumerate() {
                    if keep >> lane & 1 != 0 {
                        let s = BsdfSample {
                            wi: Vec3::new(dx[lane], dy[lane], dz[lane]),
                            weight: Rgb::new(wr[lane], wg[lane], wb[lane]),
                            pdf: p[lane],
                        };
                        out.set(k, Some(s));
                    }
                }
            },
        );
    }

    /// The first step of [`Composite::sample_block`]: per query above the surface, the
    /// component its `uc` chooses (0 diffuse, k lobe k - 1; [`NO_COMPONENT`] where the
    /// weights sum to zero) and what is left of `uc` within it, weights a lane vector at a
    /// time; the diffuse component's direction is drawn on the way.
    fn choose_components(
        &self,
        wo: Vec3Cols,
        u: Vec2Cols,
        uc: &[f32],
        choice: &mut [(usize, f32)],
        wi: &mut BlockDirections,
    ) {
        simd::chunks_where(
            wo.len(),
            |k| !(wo.z()[k] <= 0.0),
            |idx| {
                let w = self.lane_weights(f32xn::new(simd::lanes_of(idx, |k| wo.z()[k])));
                let lane_uc = f32xn::new(simd::lanes_of(idx, |k| uc[k]));
                let (chosen, uc_rest) =
                    Self::choose(lane_uc, &w.w[..self.lobes.len() + 1], w.total);
                // Without diffuse weight no query chooses the diffuse component: its
                // directions are not drawn.
                let diffuse = match self.diffuse.luminance() > 0.0 {
                    true => {
                        let [ux, uy] = u.lanes_of(idx);
                        simd::arrays3(cosine_hemisphere(ux, uy))
                    }
                    false => [[0.0; simd::LANES]; 3],
                };
                let (total, chosen, uc_rest) =
                    (w.total.to_array(), chosen.to_array(), uc_rest.to_array());
                // Without a branch on the choice, a coin flip between components.
                for (lane, &k) in idx.iter().enumerate() {
                    let c = if total[lane] > 0.0 {
                        chosen[lane] as usize
                    } else {
                        NO_COMPONENT
                    };
                    choice[k] = (c, uc_rest[lane]);
                    for (col, d) in wi.xyz.iter_mut().zip(&diffuse) {
                        col[k] = d[lane];
                    }
                    wi.drawn[k] = c == 0;
                }
            },
        );
    }

    /// The second step of [`Composite::sample_block`]: each lobe samples the queries that
    /// chose it as one batch ([`Lobe::sample_batch`]), so that no lane samples a lobe its
    /// query did not choose.
    fn sample_chosen_lobes(
        &self,
        wo: Vec3Cols,
        u: Vec2Cols,
        choice: &[(usize, f32)],
        wi: &mut BlockDirections,
    ) {
        let mut order = [0u32; SAMPLE_BLOCK];
        let mut starts = [0usize; MAX_INLINE + 1];
        let starts = &mut starts[..self.lobes.len() + 1];
        // Lobe j + 1's queries (the diffuse component's and unchosen ones in no group).
        let lobe_of = |k: usize| match choice[k].0 {
            0 | NO_COMPONENT => None,
            c => Some(c - 1),
        };
        crate::grouping::group_stable(choice.len(), lobe_of, starts, &mut order);
        let m = choice.len();
        // One lobe chosen by every query (a material of one lobe and no diffuse weight,
        // or a lobe that dominates at these `wo`): the block is its batch, read in place.
        if let Some(j) = (0..self.lobes.len()).find(|&j| starts[j + 1] - starts[j] == m) {
            let mut rest = [0.0f32; SAMPLE_BLOCK];
            for (r, c) in rest.iter_mut().zip(choice) {
                *r = c.1;
            }
            let (wi_cols, drawn) = wi.cols_mut(m);
            self.lobes[j]
                .1
                .sample_batch(wo, u, &rest[..m], wi_cols, drawn);
            return;
        }
        let mut batch_wo = BlockDirections::new();
        let mut batch_u = [[0.0f32; SAMPLE_BLOCK]; 2];
        let mut batch_uc = [0.0f32; SAMPLE_BLOCK];
        let mut batch_wi = BlockDirections::new();
        for (j, (_, lobe)) in self.lobes.iter().enumerate() {
            let idx = &order[starts[j]..starts[j + 1]];
            let len = idx.len();
            if len == 0 {
                continue;
            }
            for (q, &k) in idx.iter().enumerate() {
                let k = k as usize;
                batch_wo.set(q, wo.get(k));
                let uk = u.get(k);
                (batch_u[0][q], batch_u[1][q], batch_uc[q]) = (uk.x, uk.y, choice[k].1);
            }
            let (wi_cols, drawn) = batch_wi.cols_mut(len);
            lobe.sample_batch(
                batch_wo.cols(len),
                Vec2Cols::of([&batch_u[0][..len], &batch_u[1][..len]]),
                &batch_uc[..len],
                wi_cols,
                drawn,
            );
            for (q, &k) in idx.iter().enumerate() {
                let k = k as usize;
                wi.set(k, batch_wi.get(q));
                wi.drawn[k] = batch_wi.drawn[q];
            }
        }
    }

    /// The component `uc` chooses among the weights `w` (summing to `total`), as a float
    /// index, and what is left of `uc` within it; once for one query and lanes.
    #[inline(always)]
    fn choose<T: Num>(uc: T, w: &[T], total: T) -> (T, T) {
        let n = w.len();
        let mut target = uc * total;
        let mut done = lt(target, w[0]);
        let mut chosen = select(done, T::of(0.0), T::of((n - 1) as f64));
        let mut w_chosen = select(done, w[0], w[n - 1]);
        target = select(done, target, target - w[0]);
        for (k, &wk) in w.iter().enumerate().skip(1) {
            let found = !done & lt(target, wk);
            chosen = select(found, T::of(k as f64), chosen);
            w_chosen = select(found, wk, w_chosen);
            done = done | found;
            target = select(done, target, target - wk);
        }
        let rest = target / maximum(w_chosen, T::of(f32::MIN_POSITIVE as f64));
        (
            chosen,
            clamp(rest, T::of(0.0), T::of((1.0 - f32::EPSILON / 2.0) as f64)),
        )
    }

    /// The component weights of `LANES` outgoing directions (lane by lane
    /// [`Composite::weights`]: the same bins, values and sums).
    fn lane_weights(&self, wo_z: f32xn) -> LaneWeights {
        let bin = (wo_z * f32xn::splat(ALBEDO_BINS as f32))
            .trunc_int()
            .max(i32xn::splat(0))
            .min(i32xn::splat(ALBEDO_BINS as i32 - 1));
        let mut w = [f32xn::splat(0.0); MAX_INLINE + 1];
        w[0] = f32xn::splat(self.diffuse.luminance().max(0.0));
        let mut total = w[0];
        for (k, t) in self.lobe_weights.iter().enumerate() {
            w[k + 1] = simd::gather(t, bin);
            total += w[k + 1];
        }
        LaneWeights { w, total }
    }

    /// [`Bsdf::eval`] and the mixture density ([`Composite::mixture_pdf`], before the test of
    /// a positive total) of `LANES` pairs above the surface, lane by lane bit for bit: each
    /// lobe's value and density from its [`Lobe::eval_pdf_xn`], added by the terms one pair
    /// is mixed with ([`add_lobe_value`], [`add_lobe_density`]).
    fn mix_lanes(&self, wo: Vec3xN, wi: Vec3xN, w: &LaneWeights) -> (RgbxN, f32xn) {
        let mut f = self.diffuse_value();
        let mut pdf = w.w[0] * cosine_hemisphere_pdf(wi.z);
        for (k, (c, l)) in self.lobes.iter().enumerate() {
            let (v, p) = l.eval_pdf_xn(wo, wi);
            add_lobe_value(&mut f, *c, [v.r, v.g, v.b]);
            add_lobe_density(&mut pdf, w.w[k + 1], p);
        }
        let [r, g, b] = f;
        (RgbxN::new(r, g, b), pdf / w.total)
    }

    /// The mixture's value from its lobes' values `v(k)` (one pair or lanes).
    #[inline(always)]
    fn mixed_value<T: Num>(&self, v: impl Fn(usize) -> [T; 3]) -> [T; 3] {
        let mut f = self.diffuse_value();
        for (k, (c, _)) in self.lobes.iter().enumerate() {
            add_lobe_value(&mut f, *c, v(k));
        }
        f
    }

    /// The diffuse term of the mixture's value, `diffuse / pi`.
    #[inline(always)]
    fn diffuse_value<T: Num>(&self) -> [T; 3] {
        (self.diffuse * FRAC_1_PI)
            .to_array()
            .map(|x| T::of(x as f64))
    }

    /// The mixture's density from its lobes' densities `p(k)` and the component weights `w`
    /// (summing to `total`), one pair or lanes.
    #[inline(always)]
    fn mixed_density<T: Num>(&self, wi_z: T, w: &[T], total: T, p: impl Fn(usize) -> T) -> T {
        let mut pdf = w[0] * cosine_hemisphere_pdf(wi_z);
        for k in 0..self.lobes.len() {
            // A lobe of no weight anywhere adds nothing: its density is not evaluated.
            if all::<T>(le(w[k + 1], T::of(0.0))) {
                continue;
            }
            add_lobe_density(&mut pdf, w[k + 1], p(k));
        }
        pdf / total
    }

    #[inline]
    fn mixture_pdf(&self, wo: Vec3, wi: Vec3, w: &[f32], total: f32) -> f32 {
        self.mixed_density(wi.z, w, total, |k| self.lobes[k].1.pdf(wo, wi))
    }
}

/// Calls `each(idx, wo, wi)` with the pairs `idx` of (`wo`, `wi`) where both lie above the
/// surface, `LANES` at a time in SIMD lanes (the last chunk's lanes past its length are
/// copies of its last pair).
#[inline(always)]
fn pairs_above(wo: Vec3Cols, wi: Vec3Cols, mut each: impl FnMut(&[usize], Vec3xN, Vec3xN)) {
    let above = |k: usize| !(wo.z()[k] <= 0.0 || wi.z()[k] <= 0.0);
    simd::chunks_where(wo.len(), above, |idx| {
        each(idx, wo.lanes_of(idx), wi.lanes_of(idx))
    });
}

/// Adds a lobe of colour `c` and value `v` to the mixture's value `f` (one pair or
/// lanes): `c max(v, 0)` where `v` is finite in every channel.
#[inline(always)]
fn add_lobe_value<T: Num>(f: &mut [T; 3], c: Rgb, v: [T; 3]) {
    let finite = is_finite(v[0]) & is_finite(v[1]) & is_finite(v[2]);
    let c = c.to_array();
    for ch in 0..3 {
        let added = f[ch] + T::of(c[ch] as f64) * maximum(v[ch], T::of(0.0));
        f[ch] = select(finite, added, f[ch]);
    }
}

/// Adds a lobe of weight `wk` and density `p` to the mixture's (unnormalized) density
/// (one pair or lanes): the terms of positive weight.
#[inline(always)]
fn add_lobe_density<T: Num>(pdf: &mut T, wk: T, p: T) {
    *pdf = select(gt(wk, T::of(0.0)), *pdf + wk * p, *pdf);
}
