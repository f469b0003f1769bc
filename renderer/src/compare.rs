//! Image comparison: error metrics between a test image and a reference (RMSE, relative
//! MSE, PSNR, SSIM, mean FLIP), and the noise-aware per-pixel z-test used to validate
//! renders against Mitsuba 3 references (the test of Mitsuba's `test_renders.py`: each
//! pixel's difference divided by the combined standard deviation of the two means, two-sided
//! normal p-values, and a Sidak correction over all pixels and channels).
//!
//! - RMSE = sqrt(mean over pixels and channels of (a - b)^2); PSNR = 20 log10(peak / RMSE)
//!   with peak the largest channel value of either image, at least 1 (OpenImageIO
//!   `idiff`'s definition, so that the two tools agree).
//! - relMSE = mean((a - b)^2 / (b^2 + 0.01)) (Rousselle et al. 2011), b the reference.
//! - SSIM (Wang et al. 2004) on the luminance of the tonemapped images (image-compare's
//!   MSSIM), FLIP (Andersson et al. 2020, NVIDIA's implementation through nv-flip) on the
//!   tonemapped sRGB images: HDR inputs are scaled by 2^exposure, clamped and sRGB-encoded
//!   first, as `lobe render` does for its PNGs.

use crate::Rgb;
use crate::error::{Error, Result};
use crate::film::{Image, tonemap};

/// Metrics of a test image against a reference.
#[derive(Clone, Debug, PartialEq)]
pub struct Metrics {
    pub rmse: f64,
    pub rel_mse: f64,
    pub psnr: f64,
    pub ssim: f64,
    pub flip: f64,
}

impl Metrics {
    pub fn get(&self, name: &str) -> Option<f64> {
        Some(match name {
            "rmse" => self.rmse,
            "relmse" => self.rel_mse,
            "psnr" => self.psnr,
            "ssim" => self.ssim,
            "flip" => self.flip,
            _ => return None,
        })
    }
    pub const NAMES: &'static [&'static str] = &["rmse", "relmse", "psnr", "ssim", "flip"];
}

/// Refuses pixels that are NaN or infinite: every metric of an image holding one would
/// be NaN or infinite too, and a threshold on it would pass or fail by accident. `what`
/// names the image ("the test image", a file name) in the one-line error, which counts
/// them.
pub fn check_finite(pixels: &[Rgb], what: &str) -> Result<()> {
    let bad = pixels.iter().filter(|p| !p.is_finite()).count();
    if bad > 0 {
        return Err(Error::Other(format!(
            "{what}: {bad} of {} pixels are non-finite (NaN or infinite); expected finite pixels to compare",
            pixels.len()
        )));
    }
    Ok(())
}

/// Refuses a variance image of another size than its image, and variances that are
/// non-finite or negative.
fn check_variance(image: &Image, what: &str) -> Result<()> {
    let variance = &image.variance;
    if variance.len() != image.pixels.len() {
        return Err(Error::Other(format!(
            "{what}: {} pixels; expected one per pixel of the {}x{} image",
            variance.len(),
            image.width,
            image.height
        )));
    }
    check_finite(variance, what)?;
    let negative = variance.iter().filter(|v| v.min_component() < 0.0).count();
    if negative > 0 {
        return Err(Error::Other(format!(
            "{what}: {negative} pixels are negative; expected variances >= 0"
        )));
    }
    Ok(())
}

/// The checks every comparison makes first: equal sizes and finite pixels.
fn comparable(test: &Image, reference: &Image) -> Result<()> {
    same_size(test, reference)?;
    check_finite(&test.pixels, "the test image")?;
    check_finite(&reference.pixels, "the reference image")
}

fn same_size(a: &Image, b: &Image) -> Result<()> {
    if a.width != b.width || a.height != b.height {
        return Err(Error::Other(format!(
            "the images differ in size: {}x{} against {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    Ok(())
}

/// RMSE, relative MSE and PSNR.
pub fn pixel_errors(test: &Image, reference: &Image) -> Result<(f64, f64, f64)> {
    comparable(test, reference)?;
    let (mut se, mut rel, mut peak) = (0.0f64, 0.0f64, 1.0f64);
    for (a, b) in test.pixels.iter().zip(&reference.pixels) {
        for (x, y) in a.to_array().into_iter().zip(b.to_array()) {
            let d = x as f64 - y as f64;
            se += d * d;
            rel += d * d / (y as f64 * y as f64 + 0.01);
            peak = peak.max(x as f64).max(y as f64);
        }
    }
    let n = (test.pixels.len() * 3).max(1) as f64;
    let rmse = (se / n).sqrt();
    let psnr = if rmse > 0.0 {
        20.0 * (peak / rmse).log10()
    } else {
        f64::INFINITY
    };
    Ok((rmse, rel / n, psnr))
}

/// All metrics; `exposure` (stops) applies to the tonemapping for SSIM and FLIP.
pub fn metrics(test: &Image, reference: &Image, exposure: f32) -> Result<(Metrics, Vec<f32>)> {
    let (rmse, rel_mse, psnr) = pixel_errors(test, reference)?;
    let (w, h) = (test.width, test.height);
    let ta = tonemap(&test.pixels, exposure);
    let tb = tonemap(&reference.pixels, exposure);
    let gray = |rgb: &[u8]| {
        let lum: Vec<u8> = rgb
            .chunks(3)
            .map(|c| {
                (0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32)
                    .round()
                    .clamp(0.0, 255.0) as u8
            })
            .collect();
        image::GrayImage::from_raw(w, h, lum).expect("sizes match")
    };
    let ssim = if w >= 8 && h >= 8 {
        image_compare::gray_similarity_structure(
            &image_compare::Algorithm::MSSIMSimple,
            &gray(&ta),
            &gray(&tb),
        )
        .map_err(|e| Error::Other(format!("SSIM: {e}")))?
        .score
    } else {
        f64::NAN
    };
    let err = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &tb),
        nv_flip::FlipImageRgb8::with_data(w, h, &ta),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let flip = nv_flip::FlipPool::from_image(&err).mean() as f64;
    Ok((
        Metrics {
            rmse,
            rel_mse,
            psnr,
            ssim,
            flip,
        },
        err.to_vec(),
    ))
}

/// The FLIP error map as a magma-coloured 8-bit RGB image.
pub fn flip_heatmap(error: &[f32], width: u32, height: u32) -> Vec<u8> {
    let img = nv_flip::FlipImageFloat::with_data(width, height, error);
    img.apply_color_lut(&nv_flip::magma_lut()).to_vec()
}

/// The heat maps' colour scale ([`flip_heatmap`]) at `n` evenly spaced FLIP values from 0
/// to 1, as 8-bit RGB (for colour bars).
pub fn flip_colour_scale(n: usize) -> Vec<[u8; 3]> {
    let lut = nv_flip::magma_lut().to_vec();
    let entries = lut.len() / 3;
    (0..n)
        .map(|i| {
            let k = (i * (entries - 1)) / n.saturating_sub(1).max(1);
            [lut[3 * k], lut[3 * k + 1], lut[3 * k + 2]]
        })
        .collect()
}

/// The RMSE between two noisy renders with the noise taken out, its 95 % interval and the
/// noise floor ([`noise_aware_rmse`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseAwareRmse {
    /// sqrt(max(0, mean(d^2 - v))): d the pixel difference, v the sum of both images'
    /// variances of their means (unbiased for the squared difference of the converged
    /// images).
    pub rmse: f64,
    pub ci95: [f64; 2],
    /// sqrt(mean v): what noise alone adds, in quadrature, to the plain RMSE; the RMSE two
    /// renders of one scene would show.
    pub noise_floor: f64,
}

/// The error of `test` against `reference` without the bias Monte Carlo noise adds to the
/// plain RMSE (the variances of both images' pixel means are subtracted), with a 95 %
/// interval from the normal approximation per pixel (Var(d^2) = 4 D^2 v + 2 v^2 with D^2
/// estimated by d^2 - v), taken through the square root; and the noise floor. The
/// variances must be those of the pixel means: from independent runs
/// ([`mean_and_variance`]) they are; a single Sobol' render's per-pixel sample variance
/// overstates its mean's (stratification), which makes the floor an upper bound and the
/// RMSE without noise a lower bound.
pub fn noise_aware_rmse(test: &Image, reference: &Image) -> Result<NoiseAwareRmse> {
    comparable(test, reference)?;
    check_variance(test, "the test image's variance")?;
    check_variance(reference, "the reference image's variance")?;
    let (mut u, mut var_u, mut noise) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..test.pixels.len() {
        let (a, b) = (test.pixels[i].to_array(), reference.pixels[i].to_array());
        let (va, vb) = (
            test.variance[i].to_array(),
            reference.variance[i].to_array(),
        );
        for c in 0..3 {
            let d = a[c] as f64 - b[c] as f64;
            let v = va[c] as f64 + vb[c] as f64;
            let d2 = d * d - v;
            u += d2;
            noise += v;
            var_u += (4.0 * d2.max(0.0) * v + 2.0 * v * v).max(0.0);
        }
    }
    let n = 3.0 * test.pixels.len() as f64;
    let (u, half) = (u / n, 1.959_964 * var_u.sqrt() / n);
    let root = |x: f64| x.max(0.0).sqrt();
    Ok(NoiseAwareRmse {
        rmse: root(u),
        ci95: [root(u - half), root(u + half)],
        noise_floor: (noise / n).sqrt(),
    })
}

/// Outcome of the noise-aware comparison.
#[derive(Clone, Debug)]
pub struct ZTest {
    /// Smallest two-sided p-value over all tests.
    pub min_p: f64,
    /// Per-test threshold after the Sidak correction over all tests.
    pub threshold: f64,
    /// Tests whose p-value is below the threshold.
    pub failures: usize,
    /// Worst test: top-left pixel (x, y) of its block, block size, z-score.
    pub worst: (u32, u32, u32, f64),
    /// Number of tests (blocks x channels over all scales).
    pub tests: usize,
}

impl ZTest {
    pub fn passed(&self) -> bool {
        self.failures == 0
    }
}

/// Two-sided normal p-value of a z-score.
pub fn p_value(z: f64) -> f64 {
    libm::erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// Two-sided p-value of a t statistic with `dof` degrees of freedom (normal beyond 1e6):
/// I_{dof / (dof + t^2)}(dof / 2, 1 / 2).
pub fn p_value_t(t: f64, dof: f64) -> f64 {
    if !(dof < 1e6) {
        return p_value(t);
    }
    let x = dof / (dof + t * t);
    statrs::function::beta::beta_reg(dof / 2.0, 0.5, x)
}

/// Block sizes of the multi-scale test.
pub const Z_TEST_SCALES: [u32; 4] = [1, 4, 16, 64];

/// Noise-aware comparison of `test` (with the variance of its pixel means) against
/// `reference` (likewise), at a family-wise false-alarm rate `alpha`.
///
/// Mitsuba's `test_renders.py` z-tests every pixel; lobe does the same and, because a
/// small systematic error (a material 5 % too bright) is invisible to any single noisy
/// pixel but not to many together, also z-tests the mean difference over blocks of 4x4,
/// 16x16 and 64x64 pixels (and the whole image when it is smaller): a block's variance is
/// the sum of its independent pixels' variances over n^2. Because the variances are
/// themselves estimates (from `variance_dof` degrees of freedom each: a reference made of
/// 16 runs has only 15), each statistic is referred to Student's t with the
/// Welch-Satterthwaite degrees of freedom, (sum v)^2 / sum(v_i^2 / dof_i), not to the
/// normal: heavy-tailed glossy pixels would otherwise raise false alarms. The p-values of
/// all tests (every block of every scale, every channel) are Sidak-corrected together. A
/// test whose combined variance is zero passes when the difference is within
/// `1e-6 (1 + |ref|)`.
pub fn z_test(test: &Image, reference: &Image, alpha: f64) -> Result<ZTest> {
    comparable(test, reference)?;
    check_variance(test, "the test image's variance")?;
    check_variance(reference, "the reference image's variance")?;
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(Error::Other(format!(
            "z-test: expected a false-alarm rate in (0, 1), found {alpha}"
        )));
    }
    let (w, h) = (test.width, test.height);
    let scales = z_test_scales(w, h);
    let terms = PixelTerms::new(test, reference);
    let tests: usize = scales
        .iter()
        .map(|&s| (w.div_ceil(s) * h.div_ceil(s) * 3) as usize)
        .sum();
    let threshold = 1.0 - (1.0 - alpha).powf(1.0 / tests.max(1) as f64);
    let mut out = ZTest {
        min_p: 1.0,
        threshold,
        failures: 0,
        worst: (0, 0, 1, 0.0),
        tests,
    };
    for &s in &scales {
        for by in (0..h).step_by(s as usize) {
            for bx in (0..w).step_by(s as usize) {
                for (p, z) in terms.block_test((bx, by), s, reference) {
                    if p < out.min_p {
                        out.min_p = p;
                        out.worst = (bx, by, s, z);
                    }
                    // NaN fails: a test that cannot be computed cannot pass.
                    if !(p >= threshold) {
                        out.failures += 1;
                    }
                }
            }
        }
    }
    Ok(out)
}

/// The block sizes of a `w` x `h` image's test: [`Z_TEST_SCALES`] up to its size, and the
/// whole image when it is smaller than the largest.
fn z_test_scales(w: u32, h: u32) -> Vec<u32> {
    let mut scales: Vec<u32> = Z_TEST_SCALES
        .iter()
        .copied()
        .filter(|&s| s <= w.max(h))
        .collect();
    if !scales.contains(&w.max(h)) && w.max(h) < 64 {
        scales.push(w.max(h));
    }
    scales
}

/// Per pixel and channel of a z-test: the difference, the combined variance, and v^2 / dof
/// for the Welch-Satterthwaite degrees of freedom.
struct PixelTerms {
    width: u32,
    height: u32,
    diff: Vec<[f64; 3]>,
    var: Vec<[f64; 3]>,
    v2dof: Vec<[f64; 3]>,
}

impl PixelTerms {
    fn new(test: &Image, reference: &Image) -> Self {
        let n = (test.width * test.height) as usize;
        let (dof_t, dof_r) = (test.variance_dof.max(1.0), reference.variance_dof.max(1.0));
        let mut t = PixelTerms {
            width: test.width,
            height: test.height,
            diff: vec![[0.0; 3]; n],
            var: vec![[0.0; 3]; n],
            v2dof: vec![[0.0; 3]; n],
        };
        for k in 0..n {
            let (a, b) = (test.pixels[k].to_array(), reference.pixels[k].to_array());
            let (va, vb) = (
                test.variance[k].to_array(),
                reference.variance[k].to_array(),
            );
            for c in 0..3 {
                let (va, vb) = (va[c] as f64, vb[c] as f64);
                t.diff[k][c] = a[c] as f64 - b[c] as f64;
                t.var[k][c] = va + vb;
                t.v2dof[k][c] = va * va / dof_t + vb * vb / dof_r;
            }
        }
        t
    }

    /// The p-value and z of the mean difference over the `s` x `s` block at `(bx, by)`
    /// (clipped to the image), per channel: Student's t with the Welch-Satterthwaite
    /// degrees of freedom, or, where the combined variance is zero, a pass when the
    /// difference is within `1e-6 (1 + |ref|)`.
    fn block_test(&self, (bx, by): (u32, u32), s: u32, reference: &Image) -> [(f64, f64); 3] {
        let (w, h) = (self.width, self.height);
        let (mut d, mut v, mut r, mut q) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        let mut cnt = 0usize;
        for y in by..(by + s).min(h) {
            for x in bx..(bx + s).min(w) {
                let k = (y * w + x) as usize;
                let rp = reference.pixels[k].to_array();
                for c in 0..3 {
                    d[c] += self.diff[k][c];
                    v[c] += self.var[k][c];
                    q[c] += self.v2dof[k][c];
                    r[c] += rp[c] as f64;
                }
                cnt += 1;
            }
        }
        let cnt = cnt as f64;
        std::array::from_fn(|c| {
            let (dm, vm, rm) = (d[c] / cnt, v[c] / (cnt * cnt), r[c] / cnt);
            if vm > 0.0 {
                let z = dm / vm.sqrt();
                let dof = if q[c] > 0.0 {
                    v[c] * v[c] / q[c]
                } else {
                    f64::INFINITY
                };
                (p_value_t(z, dof), z)
            } else if dm.abs() <= 1e-6 * (1.0 + rm.abs()) {
                (1.0, 0.0)
            } else {
                (0.0, f64::INFINITY)
            }
        })
    }
}

/// Mean and variance of the mean, per pixel, of several independent renders.
pub fn mean_and_variance(renders: &[Image]) -> Result<Image> {
    let first = renders
        .first()
        .ok_or_else(|| Error::Other("no images to combine".into()))?;
    for (k, r) in renders.iter().enumerate() {
        same_size(r, first)?;
        check_finite(&r.pixels, &format!("render {}", k + 1))?;
    }
    let k = renders.len() as f64;
    let mut out = Image::new(first.width, first.height);
    for i in 0..first.pixels.len() {
        let mut m = [0.0f64; 3];
        let mut s2 = [0.0f64; 3];
        for r in renders {
            for (c, v) in r.pixels[i].to_array().into_iter().enumerate() {
                m[c] += v as f64;
                s2[c] += v as f64 * v as f64;
            }
        }
        let mean: [f64; 3] = m.map(|x| x / k);
        let var: [f64; 3] = std::array::from_fn(|c| {
            if k > 1.0 {
                ((s2[c] - m[c] * mean[c]) / (k - 1.0)).max(0.0) / k
            } else {
                0.0
            }
        });
        out.pixels[i] = Rgb::new(mean[0] as f32, mean[1] as f32, mean[2] as f32);
        out.variance[i] = Rgb::new(var[0] as f32, var[1] as f32, var[2] as f32);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(v: f32, var: f32) -> Image {
        let mut i = Image::new(16, 16);
        i.pixels.iter_mut().for_each(|p| *p = Rgb::splat(v));
        i.variance.iter_mut().for_each(|p| *p = Rgb::splat(var));
        i.variance_dof = 1000.0;
        i
    }

    #[test]
    fn metrics_of_known_differences() {
        let (rmse, rel, psnr) = pixel_errors(&img(0.6, 0.0), &img(0.5, 0.0)).unwrap();
        assert!((rmse - 0.1).abs() < 1e-6);
        assert!((psnr - 20.0).abs() < 1e-4);
        assert!((rel - 0.01 / 0.26).abs() < 1e-6);
        let (m, _) = metrics(&img(0.5, 0.0), &img(0.5, 0.0), 0.0).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert!((m.ssim - 1.0).abs() < 1e-9 && m.flip == 0.0);
    }

    #[test]
    fn z_test_tells_noise_from_bias() {
        // A difference of 3 sigma on one pixel out of 768 is noise at alpha = 1 %;
        // 10 sigma is not.
        let reference = img(0.5, 1e-4);
        let mut test = img(0.5, 1e-4);
        let sigma = (2e-4f32).sqrt();
        test.pixels[5] = Rgb::splat(0.5 + 3.0 * sigma);
        assert!(z_test(&test, &reference, 0.01).unwrap().passed());
        test.pixels[5] = Rgb::splat(0.5 + 10.0 * sigma);
        let r = z_test(&test, &reference, 0.01).unwrap();
        assert!(!r.passed() && r.worst.0 == 5 && r.worst.1 == 0 && r.worst.2 == 1);
        // A 0.5 sigma bias on every pixel is invisible per pixel but not in blocks.
        let mut biased = img(0.5, 1e-4);
        biased
            .pixels
            .iter_mut()
            .for_each(|p| *p = Rgb::splat(0.5 + 0.5 * sigma));
        let r = z_test(&biased, &reference, 0.01).unwrap();
        assert!(!r.passed() && r.worst.2 > 1, "{r:?}");
    }
}

#[cfg(test)]
mod noise_aware_tests {
    use super::*;

    /// A standard normal from two hashed uniforms (Box-Muller).
    fn normal(k: u64) -> f64 {
        let h = |x: u64| {
            let mut z = x.wrapping_mul(0x9e37_79b9_7f4a_7c15);
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let (u, v) = (h(2 * k + 1).max(1e-300), h(2 * k + 2));
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }

    /// An image of `truth + offset` with noise of standard deviation `sigma` per pixel,
    /// and that variance recorded.
    fn noisy(n: u32, offset: f32, sigma: f64, seed: u64) -> Image {
        let mut img = Image::new(n, n);
        for (i, (p, v)) in img.pixels.iter_mut().zip(&mut img.variance).enumerate() {
            let truth = 0.5 + 0.3 * ((i % 17) as f32 / 17.0);
            let e: [f32; 3] = std::array::from_fn(|c| {
                (sigma * normal(seed * 1_000_003 + 3 * i as u64 + c as u64)) as f32
            });
            *p = Rgb::new(
                truth + offset + e[0],
                truth + offset + e[1],
                truth + offset + e[2],
            );
            *v = Rgb::splat((sigma * sigma) as f32);
        }
        img
    }

    #[test]
    fn the_noise_is_taken_out_of_the_rmse_and_the_interval_covers_the_truth() {
        // A 1 % offset under noise four times larger: the plain RMSE sees mostly noise.
        let mut covered = 0;
        for seed in 0..40 {
            let t = noisy(64, 0.01, 0.04, 2 * seed);
            let r = noisy(64, 0.0, 0.04, 2 * seed + 1);
            let e = noise_aware_rmse(&t, &r).unwrap();
            let plain = pixel_errors(&t, &r).unwrap().0;
            assert!(plain > 0.05, "{plain}");
            assert!((e.noise_floor - 0.04 * 2f64.sqrt()).abs() < 1e-3, "{e:?}");
            covered += (e.ci95[0] <= 0.01 && 0.01 <= e.ci95[1]) as usize;
        }
        assert!(
            covered >= 34,
            "{covered} of 40 intervals cover the true 0.01"
        );
    }
}
