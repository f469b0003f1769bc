//! Speed/accuracy curves of path-traced renders, and equal-time errors read from them
//! (the equal-time comparison of Ngan, Durand and Matusik 2005's trade-off, made from a
//! fitted curve rather than one short render).
//!
//! A representation is path-traced at several sample counts on a film a quarter the size
//! across (the noise of a pixel does not depend on the film size, and the small film keeps
//! the measurement cheap). Each render's mean square distance from the representation's
//! own converged image (box-filtered down to the small film; its own noise subtracted) is
//! its noise; a power law `noise(spp) = v spp^-beta` is fitted by least squares in log-log
//! (beta is 1 for independent samples, more for stratified ones), and a line
//! `seconds(spp) = a + c spp` to the render times, with `c` scaled to the full film. The
//! error of a representation at a time budget `T` is then
//! `sqrt(bias^2 + v spp(T)^-beta)` with `spp(T) = (T - a) / c`, where `bias` is its
//! converged error against the data ([`crate::sphere_errors`]); its interval is the bias
//! interval carried through the same formula (the fitted noise term's own uncertainty is
//! not in it; [`Curve::spread`] shows how well the power law fits).

use lobe_materials::Bsdf;
use lobe_renderer::Error;
use lobe_renderer::film::Image;
use lobe_renderer::render::{RenderOptions, render};
use lobe_renderer::scene::Scene;
use std::sync::Arc;

/// Sample counts of the measured renders.
pub const CURVE_SPP: [u32; 3] = [4, 16, 64];

/// How much smaller (across) the curve's film is than the full one.
pub const FILM_DIVISOR: u32 = 4;

/// A representation's fitted speed/accuracy curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// Per measured render: spp, seconds (small film), noise (mean square).
    pub points: Vec<(u32, f64, f64)>,
    /// Noise of a 1-spp render and its decay exponent: noise = v spp^-beta.
    pub v: f64,
    pub beta: f64,
    /// Seconds of a full-film render: a + c spp.
    pub a: f64,
    pub c: f64,
    /// Largest ratio between a measured noise and the fitted curve's (1: exact fit).
    pub spread: f64,
}

impl Curve {
    /// Seconds of a full-film render at `spp`.
    pub fn seconds(&self, spp: f64) -> f64 {
        self.a + self.c * spp
    }

    /// The spp a full-film render affords in `seconds` (at least 1).
    pub fn spp_in(&self, seconds: f64) -> f64 {
        ((seconds - self.a) / self.c.max(1e-12)).max(1.0)
    }

    /// Mean square noise of a render at `spp`.
    pub fn noise(&self, spp: f64) -> f64 {
        self.v * spp.max(1.0).powf(-self.beta)
    }

    /// The RMSE against the data of a render at `spp` whose converged RMSE is `bias`.
    pub fn rmse(&self, spp: f64, bias: f64) -> f64 {
        (bias * bias + self.noise(spp)).sqrt()
    }
}

/// The box-filtered average of `img` over `k` x `k` blocks, with the variance of that
/// average.
fn downsample(img: &Image, k: u32) -> Image {
    let (w, h) = (img.width / k, img.height / k);
    let mut out = Image::new(w, h);
    let n = (k * k) as f32;
    for y in 0..h {
        for x in 0..w {
            let mut m = lobe_materials::Rgb::splat(0.0);
            let mut v = lobe_materials::Rgb::splat(0.0);
            for j in 0..k {
                for i in 0..k {
                    let p = ((y * k + j) * img.width + x * k + i) as usize;
                    m += img.pixels[p];
                    if let Some(var) = img.variance.get(p) {
                        v += *var;
                    }
                }
            }
            out.pixels[(y * w + x) as usize] = m / n;
            out.variance[(y * w + x) as usize] = v / (n * n);
        }
    }
    out
}

/// Mean square difference over pixels and channels, less the converged image's variance.
fn noise_of(render: &Image, converged: &Image) -> f64 {
    let mut sum = 0.0;
    for ((a, b), var) in render
        .pixels
        .iter()
        .zip(&converged.pixels)
        .zip(&converged.variance)
    {
        let d = *a - *b;
        for c in 0..3 {
            sum += (d.to_array()[c] as f64).powi(2) - var.to_array()[c] as f64;
        }
    }
    (sum / (3 * render.pixels.len()) as f64).max(0.0)
}

/// Least squares line y = p + q x through the points.
fn line(xs: &[f64], ys: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let q = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (my - q * mx, q)
}

/// The curve of material `b` in `scene` (the full film's stage; the curve renders it at
/// 1/[`FILM_DIVISOR`] across) against its converged full-film image `converged`.
pub fn measure(scene: &mut Scene, b: &Arc<dyn Bsdf>, converged: &Image) -> Result<Curve, Error> {
    let (fw, fh) = (scene.settings.width, scene.settings.height);
    let k = FILM_DIVISOR;
    if fw % k != 0 || fh % k != 0 || fw < k || fh < k {
        return Err(Error::Other(format!(
            "speed/accuracy curve: expected a film a multiple of {k} pixels across, found {fw}x{fh}"
        )));
    }
    let target = downsample(converged, k);
    scene.settings.width = fw / k;
    scene.settings.height = fh / k;
    scene.world.shapes[0].material = b.clone();
    let mut points = Vec::new();
    for &spp in &CURVE_SPP {
        scene.settings.spp = spp;
        let (img, stats) = render(scene, &RenderOptions::default())?;
        points.push((spp, stats.seconds, noise_of(&img, &target)));
    }
    scene.settings.width = fw;
    scene.settings.height = fh;
    Ok(fit(&points, (k * k) as f64))
}

/// The curve through measured points; `scale` is the ratio of full to small film pixels.
pub fn fit(points: &[(u32, f64, f64)], scale: f64) -> Curve {
    let xs: Vec<f64> = points.iter().map(|p| (p.0 as f64).ln()).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.2.max(1e-300).ln()).collect();
    let (lv, slope) = line(&xs, &ys);
    let (v, beta) = match points.iter().all(|p| p.2 > 0.0) {
        true => (lv.exp(), -slope),
        false => (0.0, 1.0),
    };
    let spps: Vec<f64> = points.iter().map(|p| p.0 as f64).collect();
    let secs: Vec<f64> = points.iter().map(|p| p.1).collect();
    let (a, c) = line(&spps, &secs);
    let fitted = |spp: f64| v * spp.powf(-beta);
    let spread = points
        .iter()
        .filter(|p| p.2 > 0.0)
        .map(|p| {
            let r = p.2 / fitted(p.0 as f64);
            r.max(1.0 / r)
        })
        .fold(1.0, f64::max);
    Curve {
        points: points.to_vec(),
        v,
        beta,
        a: a.max(0.0),
        c: (c * scale).max(1e-12),
        spread,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_power_law_and_a_line_are_recovered() {
        let pts: Vec<(u32, f64, f64)> = [4u32, 16, 64]
            .iter()
            .map(|&s| (s, 0.01 + 0.002 * s as f64, 0.5 * (s as f64).powf(-1.2)))
            .collect();
        let c = fit(&pts, 16.0);
        assert!(
            (c.v - 0.5).abs() < 1e-9 && (c.beta - 1.2).abs() < 1e-9,
            "{c:?}"
        );
        assert!(
            (c.a - 0.01).abs() < 1e-9 && (c.c - 0.032).abs() < 1e-9,
            "{c:?}"
        );
        assert!((c.spread - 1.0).abs() < 1e-9);
        assert!((c.spp_in(c.seconds(100.0)) - 100.0).abs() < 1e-6);
        assert!((c.rmse(1.0, 0.3) - (0.09f64 + 0.5).sqrt()).abs() < 1e-12);
    }
}
