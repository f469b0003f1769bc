//! Image error that one pixel cannot decide: the median-of-means RMSE (Lugosi and
//! Mendelson, "Mean estimation and regression under heavy-tailed distributions", 2019: the
//! median of the means of disjoint groups estimates a mean with heavy tails far better than
//! the plain mean), with the pixels that are outliers against it. The speed/accuracy
//! trade-off study reports it next to the plain RMSE, so that a single firefly (a rare
//! sample of huge weight) cannot make one representation look 200x worse than the others.
//!
//! The pixels are dealt into [`GROUPS`] groups by a fixed permutation of their index
//! (every group spreads over the whole image); each group's mean squared error (over pixels
//! and channels) is computed, and the result is the square root of the median group. An
//! outlier is a pixel whose squared error is above [`OUTLIER_FACTOR`] times that median.

use crate::error::{Error, Result};
use crate::film::Image;

/// Groups of the median of means.
pub const GROUPS: usize = 16;
/// A pixel whose squared error exceeds this multiple of the median-of-means MSE is reported
/// as an outlier.
pub const OUTLIER_FACTOR: f64 = 1000.0;

/// Plain and robust error of an image against a reference.
#[derive(Clone, Debug, PartialEq)]
pub struct RobustError {
    /// sqrt(mean squared error) over every pixel and channel.
    pub rmse: f64,
    /// sqrt(median over [`GROUPS`] groups of the group's mean squared error).
    pub median_of_means_rmse: f64,
    /// Pixels whose squared error exceeds [`OUTLIER_FACTOR`] x the median-of-means MSE.
    pub outliers: usize,
    /// The worst pixel: its squared error (mean over channels) and its (x, y).
    pub worst: (f64, u32, u32),
}

/// The plain and median-of-means errors of `test` against `reference` (same size, finite).
pub fn robust_error(test: &Image, reference: &Image) -> Result<RobustError> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(Error::Other(format!(
            "the images differ in size: {}x{} against {}x{}",
            test.width, test.height, reference.width, reference.height
        )));
    }
    let n = test.pixels.len();
    let per_pixel: Vec<f64> = test
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(a, b)| {
            let d = (*a - *b).to_array();
            d.iter().map(|&x| x as f64 * x as f64).sum::<f64>() / 3.0
        })
        .collect();
    let mut sums = [0.0f64; GROUPS];
    let mut counts = [0usize; GROUPS];
    for (k, &e) in per_pixel.iter().enumerate() {
        // A fixed scramble (odd multiplier, modulo 2^64) so groups are not image columns.
        let g = ((k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 60) as usize % GROUPS;
        sums[g] += e;
        counts[g] += 1;
    }
    let mut means: Vec<f64> = (0..GROUPS)
        .filter(|&g| counts[g] > 0)
        .map(|g| sums[g] / counts[g] as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    let median = match means.len() {
        0 => 0.0,
        m if m % 2 == 1 => means[m / 2],
        m => 0.5 * (means[m / 2 - 1] + means[m / 2]),
    };
    let total: f64 = per_pixel.iter().sum();
    let (worst_k, worst) =
        per_pixel.iter().enumerate().fold(
            (0, 0.0f64),
            |(bk, bv), (k, &v)| if v > bv { (k, v) } else { (bk, bv) },
        );
    let w = test.width.max(1) as usize;
    Ok(RobustError {
        rmse: (total / n.max(1) as f64).sqrt(),
        median_of_means_rmse: median.sqrt(),
        outliers: per_pixel
            .iter()
            .filter(|&&e| e > OUTLIER_FACTOR * median)
            .count(),
        worst: (worst, (worst_k % w) as u32, (worst_k / w) as u32),
    })
}
