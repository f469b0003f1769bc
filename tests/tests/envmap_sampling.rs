//! The environment-map sampler: its density integrates to one over the sphere, samples
//! agree with `eval` and `pdf`, and a chi-square test (Pearson, cells with expected count
//! below 5 pooled, significance 1 %) matches sampled directions to the density.

use glam::{Mat3, Vec2, Vec3};
use lobe_materials::Rgb;
use lobe_renderer::image_io::RgbImage;
use lobe_renderer::lights::envmap::EnvMap;
use lobe_tests::chi2_test;
use std::f64::consts::PI;

/// A synthetic HDR map: a smooth gradient, a bright "sun" and a black band.
fn synthetic(w: usize, h: usize) -> RgbImage {
    let mut pixels = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let (u, v) = (i as f32 / w as f32, j as f32 / h as f32);
            let mut c = Rgb::new(0.2 + u, 0.5 * v, 0.3) * (1.0 + (6.0 * u).sin().abs());
            if (u - 0.3).abs() < 0.03 && (v - 0.25).abs() < 0.04 {
                c = Rgb::new(200.0, 180.0, 150.0);
            }
            if (0.6..0.7).contains(&v) {
                c = Rgb::ZERO;
            }
            pixels.push(c);
        }
    }
    RgbImage {
        width: w,
        height: h,
        pixels,
    }
}

fn env() -> EnvMap {
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.7);
    EnvMap::new(&synthetic(64, 32), 1.5, rot)
}

/// The synthetic map with MIS compensation: zero density wherever the map is darker than
/// its mean.
fn env_compensated() -> EnvMap {
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.7);
    EnvMap::with_mis_compensation(&synthetic(64, 32), 1.5, rot, true)
}

/// Unit direction from (cos theta, phi) around +z.
fn dir(z: f64, phi: f64) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
}

#[test]
fn density_integrates_to_one() {
    for (name, e) in [("plain", env()), ("MIS-compensated", env_compensated())] {
        // Midpoint rule in (cos theta, phi): equal-area cells.
        let (nz, np) = (800, 1600);
        let (mut acc, mut zero) = (0.0f64, 0usize);
        for a in 0..nz {
            for b in 0..np {
                let z = -1.0 + 2.0 * (a as f64 + 0.5) / nz as f64;
                let phi = 2.0 * PI * (b as f64 + 0.5) / np as f64;
                let p = e.pdf(dir(z, phi)) as f64;
                acc += p;
                zero += (p == 0.0) as usize;
            }
        }
        let integral = acc * 4.0 * PI / (nz * np) as f64;
        assert!(
            (integral - 1.0).abs() < 5e-3,
            "{name}: integral of the pdf: {integral}"
        );
        // Compensation leaves the darker part of the map to BSDF sampling.
        if name == "plain" {
            assert!(zero < nz * np / 8, "{name}: {zero} zero-density cells");
        } else {
            assert!(zero > nz * np / 4, "{name}: only {zero} zero-density cells");
        }
    }
}

#[test]
fn samples_agree_with_eval_and_pdf() {
    for e in [env(), env_compensated()] {
        for i in 0..2000 {
            let u = Vec2::new(((i as f32) * 0.618034).fract(), (i as f32 + 0.5) / 2000.0);
            let Some((d, li, pdf)) = e.sample(u) else {
                continue;
            };
            assert!((d.length() - 1.0).abs() < 1e-4);
            let (l2, p2) = e.eval_pdf(d);
            assert!(
                (li - l2).max_component().abs() <= 1e-3 * li.max_component().max(1.0),
                "{li:?} vs {l2:?}"
            );
            assert!((pdf - p2).abs() <= 2e-3 * pdf, "pdf {pdf} vs {p2}");
            assert!(
                pdf > 0.0 && li.max_component() > 0.0,
                "sampled a black direction"
            );
        }
    }
}

/// Pixels an in-memory image may hold but a file may not (negative, NaN, infinite) read as
/// zero: radiance and density stay finite and agree between `sample` and `eval_pdf`.
#[test]
fn bad_pixels_read_as_zero() {
    let mut img = synthetic(32, 16);
    img.pixels[5] = Rgb::new(-3.0, 1.0, 2.0);
    img.pixels[40] = Rgb::new(f32::NAN, 1.0, 1.0);
    img.pixels[41] = Rgb::new(f32::INFINITY, 0.5, 0.5);
    let e = EnvMap::new(&img, 1.0, Mat3::IDENTITY);
    for i in 0..4000 {
        let u = Vec2::new(((i as f32) * 0.618034).fract(), (i as f32 + 0.5) / 4000.0);
        let Some((d, li, pdf)) = e.sample(u) else {
            continue;
        };
        assert!(li.is_finite() && li.min_component() >= 0.0 && pdf.is_finite() && pdf > 0.0);
        let (l2, p2) = e.eval_pdf(d);
        assert!(
            l2.is_finite() && (pdf - p2).abs() <= 2e-3 * pdf,
            "pdf {pdf} vs {p2}"
        );
    }
}

/// Counts of sampled directions over an equal-area (cos theta, phi) grid.
fn histogram(e: &EnvMap, samples: impl Iterator<Item = Vec2>, nz: usize, np: usize) -> Vec<f64> {
    let mut observed = vec![0.0f64; nz * np];
    for u in samples {
        if let Some((d, _, _)) = e.sample(u) {
            let z = (d.z as f64).clamp(-1.0, 1.0 - 1e-12);
            let mut phi = (d.y as f64).atan2(d.x as f64);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            let a = (((z + 1.0) / 2.0 * nz as f64) as usize).min(nz - 1);
            let b = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
            observed[a * np + b] += 1.0;
        }
    }
    observed
}

/// Expected counts of `n` samples per cell: the pdf integrated over each cell
/// (16 x 16 midpoint sub-cells).
fn expected_counts(e: &EnvMap, nz: usize, np: usize, n: usize) -> Vec<f64> {
    let mut expected = vec![0.0f64; nz * np];
    let sub = 16;
    let cell_area = 4.0 * PI / (nz * np) as f64;
    for a in 0..nz {
        for b in 0..np {
            let mut acc = 0.0;
            for i in 0..sub {
                for j in 0..sub {
                    let z = -1.0 + 2.0 * (a as f64 + (i as f64 + 0.5) / sub as f64) / nz as f64;
                    let phi = 2.0 * PI * (b as f64 + (j as f64 + 0.5) / sub as f64) / np as f64;
                    acc += e.pdf(dir(z, phi)) as f64;
                }
            }
            expected[a * np + b] = acc / (sub * sub) as f64 * cell_area * n as f64;
        }
    }
    expected
}

#[test]
fn chi_square_of_sampled_directions() {
    // The synthetic map, and an odd-sized one (the sampling hierarchy zero-pads both
    // dimensions at several levels) with a one-pixel sun 2500 times the sky.
    let mut odd = synthetic(37, 19);
    for (k, px) in odd.pixels.iter_mut().enumerate() {
        if k % 37 == 30 && k / 37 == 5 {
            *px = Rgb::splat(500.0);
        } else if px.max_component() > 100.0 {
            *px = Rgb::splat(0.2);
        }
    }
    let rot = Mat3::from_axis_angle(Vec3::new(-0.2, 1.0, 0.5).normalize(), 1.1);
    for (name, e) in [
        ("synthetic 64x32", env()),
        ("synthetic 64x32, MIS-compensated", env_compensated()),
        ("odd 37x19 with a sun", EnvMap::new(&odd, 1.0, rot)),
    ] {
        let (nz, np, n) = (24usize, 48usize, 400_000usize);
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut rnd = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        let observed = histogram(&e, (0..n).map(|_| Vec2::new(rnd(), rnd())), nz, np);
        let (stat, dof, p) = chi2_test(&observed, &expected_counts(&e, nz, np, n), 5.0);
        eprintln!("{name}: chi2 = {stat:.1}, dof = {dof}, p = {p:.4}");
        assert!(
            p > 0.01,
            "{name}: chi-square test rejects the sampler: chi2 = {stat:.1}, dof = {dof}, p = {p:.2e}"
        );
    }
}

#[test]
fn chi_square_detects_a_wrong_density() {
    // The same test must fail for a sampler whose pdf is off: compare the samples of one
    // map with the density of another (a 30 % brighter sun).
    let e = env();
    let mut img = synthetic(64, 32);
    for p in img.pixels.iter_mut() {
        if p.r > 100.0 {
            *p *= 1.3;
        }
    }
    let wrong = EnvMap::new(
        &img,
        1.5,
        Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.7),
    );
    let (nz, np, n) = (12usize, 24usize, 200_000usize);
    let samples = (0..n).map(|k| {
        Vec2::new(
            ((k as f64 * 0.754877666) % 1.0) as f32,
            ((k as f64 * 0.569840291) % 1.0) as f32,
        )
    });
    let observed = histogram(&e, samples, nz, np);
    let (_, _, p) = chi2_test(&observed, &expected_counts(&wrong, nz, np, n), 5.0);
    assert!(p < 1e-6, "a 30 % brighter sun must be detected (p = {p})");
}

/// The batched forms the wavefront integrator uses (`sample_many`, `eval_pdf_many`: eight
/// SIMD lanes at a time) equal the one-at-a-time `sample` and `eval_pdf` bit for bit, on
/// rotated, compensated, black and odd-sized maps, for batch lengths that do not fill the
/// last eight lanes, and at the poles and the u seam.
#[test]
fn batched_lookups_equal_single_ones() {
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.7);
    let black = RgbImage {
        width: 5,
        height: 3,
        pixels: vec![Rgb::ZERO; 15],
    };
    let maps = [
        env(),
        env_compensated(),
        EnvMap::new(&synthetic(37, 19), 0.8, Mat3::IDENTITY),
        EnvMap::new(&black, 1.0, rot),
    ];
    let bits = |v: Vec3, c: Rgb, p: f32| {
        [v.x, v.y, v.z, c.r, c.g, c.b, p].map(|x| if x == 0.0 { 0 } else { x.to_bits() })
    };
    for e in &maps {
        for n in [1usize, 7, 8, 9, 16, 24, 203] {
            let mut us: Vec<Vec2> = (0..n)
                .map(|i| {
                    Vec2::new(
                        ((i as f32) * 0.618_034).fract(),
                        ((i as f32) * 0.754_878 + 0.1).fract(),
                    )
                })
                .collect();
            us[0] = Vec2::new(0.0, 0.0);
            if n > 3 {
                us[1] = Vec2::new(1.0 - f32::EPSILON / 2.0, 1.0 - f32::EPSILON / 2.0);
                us[2] = Vec2::new(0.5, 0.0);
            }
            let mut wi = lobe_materials::Vec3s::zeros(n);
            let (mut li, mut pdf) = (vec![Rgb::ZERO; n], vec![0.0; n]);
            let u = lobe_materials::Vec2s::from(&us[..]);
            e.sample_many(u.cols(), wi.cols_mut(), &mut li, &mut pdf);
            let wi = wi.to_vec();
            for i in 0..n {
                let (ew, el, ep) = e.sample(us[i]).unwrap_or((Vec3::ZERO, Rgb::ZERO, 0.0));
                assert_eq!(
                    bits(wi[i], li[i], pdf[i]),
                    bits(ew, el, ep),
                    "sample {:?}",
                    us[i]
                );
            }
            let mut dirs: Vec<Vec3> = (0..n)
                .map(|i| {
                    let z = -1.0 + 2.0 * ((i as f32) * 0.618_034).fract();
                    let phi = std::f32::consts::TAU * ((i as f32) * 0.754_878).fract();
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    Vec3::new(r * phi.cos(), z, r * phi.sin())
                })
                .collect();
            dirs[0] = Vec3::Y;
            if n > 3 {
                dirs[1] = -Vec3::Y;
                dirs[2] = Vec3::new(0.0, 0.0, 1.0);
            }
            let mut out = vec![(Rgb::ZERO, 0.0); n];
            e.eval_pdf_many(lobe_materials::Vec3s::from(&dirs[..]).cols(), &mut out);
            for i in 0..n {
                let (el, ep) = e.eval_pdf(dirs[i]);
                assert_eq!(
                    bits(Vec3::ZERO, out[i].0, out[i].1),
                    bits(Vec3::ZERO, el, ep),
                    "eval_pdf {:?}",
                    dirs[i]
                );
            }
        }
    }
}
