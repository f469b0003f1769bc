//! The BSDF test battery of lobe, in the manner of Mitsuba 3's `chi2.py` and pbrt-v4's
//! `bsdfs_test.cpp`: finiteness and non-negativity over dense direction grids (including
//! grazing angles, wi = wo and the mirror direction), reciprocity, directional albedo,
//! pdf normalization, consistency of `sample` with `eval` and `pdf`, and a chi-square
//! goodness-of-fit test of `sample` against `pdf`.

use glam::{Vec2, Vec3};
use lobe_materials::Bsdf;
use std::f64::consts::PI;

/// Unit direction from angles in degrees (theta from +z, phi from +x).
pub fn dir_deg(theta: f64, phi: f64) -> Vec3 {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
}

/// Outgoing directions used by the checks: normal incidence to 89.99 degrees.
pub fn test_wos() -> Vec<Vec3> {
    let mut v = Vec::new();
    for &t in &[0.0, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.99] {
        for &p in &[0.0, 37.0, 133.0] {
            v.push(dir_deg(t, p));
        }
    }
    v
}

/// f and pdf are finite and non-negative over a dense grid of pairs, including wi = wo and
/// wi = mirror(wo); samples have finite non-negative weights and positive pdfs.
pub fn check_finite_nonnegative(name: &str, b: &dyn Bsdf) {
    let thetas: Vec<f64> = (0..=18)
        .map(|k| k as f64 * 5.0)
        .map(|t| if t >= 90.0 { 89.99 } else { t })
        .collect();
    let phis: Vec<f64> = (0..12).map(|k| k as f64 * 30.0 + 7.0).collect();
    let mut dirs: Vec<Vec3> = Vec::new();
    for &t in &thetas {
        for &p in &phis {
            dirs.push(dir_deg(t, p));
        }
    }
    for &wo in &dirs {
        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
        for wi in dirs.iter().copied().chain([wo, mirror]) {
            let f = b.eval(wo, wi);
            let pdf = b.pdf(wo, wi);
            assert!(
                f.is_finite() && f.min_component() >= 0.0,
                "{name}: f({wo}, {wi}) = {f:?}"
            );
            assert!(
                pdf.is_finite() && pdf >= 0.0,
                "{name}: pdf({wo}, {wi}) = {pdf}"
            );
        }
        for i in 0..16 {
            for j in 0..16 {
                let u = Vec2::new((i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0);
                if let Some(s) = b.sample(wo, u, (i * 16 + j) as f32 / 256.0) {
                    assert!(
                        s.weight.is_finite() && s.weight.min_component() >= 0.0,
                        "{name}: weight {:?} for wo {wo}",
                        s.weight
                    );
                    assert!(
                        s.pdf.is_finite() && s.pdf > 0.0,
                        "{name}: sample pdf {} for wo {wo}",
                        s.pdf
                    );
                    assert!(
                        (s.wi.length() - 1.0).abs() < 1e-3,
                        "{name}: |wi| = {}",
                        s.wi.length()
                    );
                }
            }
        }
    }
}

/// f(wo, wi) = f(wi, wo) to a relative 1e-3 (plus an absolute floor).
pub fn check_reciprocity(name: &str, b: &dyn Bsdf) {
    for wo in test_wos() {
        for wi in test_wos() {
            let a = b.eval(wo, wi);
            let c = b.eval(wi, wo);
            let tol = 1e-3 * a.max_component().max(c.max_component()) + 1e-6;
            assert!(
                (a - c).max_component().abs() <= tol && (c - a).max_component().abs() <= tol,
                "{name}: f({wo},{wi}) = {a:?} but f({wi},{wo}) = {c:?}"
            );
        }
    }
}

/// Stratified estimate of the directional albedo (per channel max) with `sample`.
pub fn albedo(b: &dyn Bsdf, wo: Vec3, n: usize) -> f64 {
    let mut acc = [0.0f64; 3];
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let uc = (((i * 7919 + j * 104729) % (n * n)) as f32 + 0.5) / (n * n) as f32;
            if let Some(s) = b.sample(wo, u, uc) {
                for (k, w) in s.weight.to_array().iter().enumerate() {
                    acc[k] += *w as f64;
                }
            }
        }
    }
    acc.iter().fold(0.0f64, |a, &x| a.max(x)) / (n * n) as f64
}

/// Directional albedo <= 1 + tol for every test direction.
pub fn check_albedo_bounded(name: &str, b: &dyn Bsdf, tol: f64) {
    for wo in test_wos() {
        let a = albedo(b, wo, 128);
        assert!(
            a <= 1.0 + tol,
            "{name}: directional albedo {a} > 1 at wo {wo}"
        );
    }
}

/// `sample` agrees with `eval` and `pdf`: weight = f cos / pdf, pdf = pdf(wo, wi).
pub fn check_sample_consistency(name: &str, b: &dyn Bsdf) {
    for wo in test_wos() {
        for i in 0..24 {
            for j in 0..24 {
                let u = Vec2::new((i as f32 + 0.5) / 24.0, (j as f32 + 0.5) / 24.0);
                let Some(s) = b.sample(wo, u, ((i * 24 + j) as f32 + 0.5) / 576.0) else {
                    continue;
                };
                let pdf = b.pdf(wo, s.wi);
                assert!(
                    (pdf - s.pdf).abs() <= 1e-3 * pdf.max(s.pdf) + 1e-6,
                    "{name}: sample pdf {} vs pdf() {pdf} (wo {wo}, wi {})",
                    s.pdf,
                    s.wi
                );
                let w = b.eval(wo, s.wi) * (s.wi.z / s.pdf);
                let tol = 2e-3 * w.max_component().max(s.weight.max_component()) + 1e-6;
                assert!(
                    (w - s.weight).max_component().abs() <= tol
                        && (s.weight - w).max_component().abs() <= tol,
                    "{name}: weight {:?} vs f cos / pdf {w:?}",
                    s.weight
                );
            }
        }
    }
}

/// Integral of pdf(wo, .) over the hemisphere on an equal-area grid refined to `res`.
pub fn pdf_integral(b: &dyn Bsdf, wo: Vec3, res: usize) -> f64 {
    let (nz, np) = (res, 2 * res);
    let mut acc = 0.0f64;
    for a in 0..nz {
        for c in 0..np {
            let z = (a as f64 + 0.5) / nz as f64;
            let phi = 2.0 * PI * (c as f64 + 0.5) / np as f64;
            let r = (1.0 - z * z).sqrt();
            acc += b.pdf(
                wo,
                Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32),
            ) as f64;
        }
    }
    acc * 2.0 * PI / (nz * np) as f64
}

/// Fraction of `sample` calls that return a direction.
pub fn success_rate(b: &dyn Bsdf, wo: Vec3, n: usize) -> f64 {
    let mut ok = 0usize;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let uc = (((i * 7919 + j * 104729) % (n * n)) as f32 + 0.5) / (n * n) as f32;
            ok += b.sample(wo, u, uc).is_some() as usize;
        }
    }
    ok as f64 / (n * n) as f64
}

/// The pdf integrates to the probability that `sample` succeeds (1 when it never fails).
pub fn check_pdf_normalized(name: &str, b: &dyn Bsdf, res: usize, tol: f64) {
    for wo in test_wos().into_iter().filter(|w| w.z > 0.1) {
        let integral = pdf_integral(b, wo, res);
        let rate = success_rate(b, wo, 256);
        assert!(
            (integral - rate).abs() <= tol,
            "{name}: pdf integrates to {integral} but sample succeeds {rate} of the time (wo {wo})"
        );
    }
}

/// Chi-square test of `sample` against `pdf` for one `wo`, on an equal-area grid of
/// `nz` x 2nz cells with 8 x 8 sub-samples for the expected counts. Returns the p-value.
pub fn chi2_pvalue(b: &dyn Bsdf, wo: Vec3, nz: usize, n_samples: usize, seed: u64) -> f64 {
    chi2_pvalue_sub(b, wo, nz, n_samples, seed, 8)
}

/// [`chi2_pvalue`] with `sub` x `sub` sub-samples per cell for the expected counts (for
/// piecewise-constant densities, whose jumps need a finer integration).
pub fn chi2_pvalue_sub(
    b: &dyn Bsdf,
    wo: Vec3,
    nz: usize,
    n_samples: usize,
    seed: u64,
    sub: usize,
) -> f64 {
    let np = 2 * nz;
    let mut observed = vec![0.0f64; nz * np];
    let mut state = seed.wrapping_mul(0x9e3779b97f4a7c15) | 1;
    let mut rnd = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    for _ in 0..n_samples {
        let u = Vec2::new(rnd(), rnd());
        if let Some(s) = b.sample(wo, u, rnd()) {
            let z = (s.wi.z as f64).clamp(0.0, 1.0 - 1e-12);
            let mut phi = (s.wi.y as f64).atan2(s.wi.x as f64);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            let a = ((z * nz as f64) as usize).min(nz - 1);
            let c = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
            observed[a * np + c] += 1.0;
        }
    }
    let cell = 2.0 * PI / (nz * np) as f64;
    let mut expected = vec![0.0f64; nz * np];
    for a in 0..nz {
        for c in 0..np {
            let mut acc = 0.0;
            for i in 0..sub {
                for j in 0..sub {
                    let z = (a as f64 + (i as f64 + 0.5) / sub as f64) / nz as f64;
                    let phi = 2.0 * PI * (c as f64 + (j as f64 + 0.5) / sub as f64) / np as f64;
                    let r = (1.0 - z * z).sqrt();
                    acc += b.pdf(
                        wo,
                        Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32),
                    ) as f64;
                }
            }
            expected[a * np + c] = acc / (sub * sub) as f64 * cell * n_samples as f64;
        }
    }
    crate::chi2_test(&observed, &expected, 5.0).2
}

/// Variance of the albedo estimator (weights summed over channels) with `sample`.
pub fn weight_variance(b: &dyn Bsdf, wo: Vec3, n: usize) -> f64 {
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.37) / n as f32, (j as f32 + 0.71) / n as f32);
            let uc = (((i * 7919 + j * 104729) % (n * n)) as f32 + 0.5) / (n * n) as f32;
            let w = b
                .sample(wo, u, uc)
                .map_or(0.0, |s| s.weight.luminance() as f64);
            s1 += w;
            s2 += w * w;
        }
    }
    let m = (n * n) as f64;
    s2 / m - (s1 / m) * (s1 / m)
}
