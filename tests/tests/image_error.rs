//! The median-of-means image error (lobe_renderer::error_stats) that the trade-off study
//! reports next to the RMSE: one firefly pixel decides the RMSE but not it.

use lobe_renderer::Rgb;
use lobe_renderer::error_stats::robust_error;
use lobe_renderer::film::Image;

fn noisy(w: u32, h: u32, seed: u64) -> Image {
    let mut img = Image::new(w, h);
    let mut s = seed.wrapping_mul(0x9e3779b97f4a7c15) | 1;
    for p in &mut img.pixels {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let u = (s >> 40) as f32 / (1u64 << 24) as f32;
        *p = Rgb::splat(0.5 + 0.1 * (u - 0.5));
    }
    img
}

#[test]
fn one_firefly_decides_the_rmse_but_not_the_median_of_means() {
    let reference = Image {
        pixels: vec![Rgb::splat(0.5); 128 * 128],
        ..Image::new(128, 128)
    };
    let clean = noisy(128, 128, 1);
    let mut firefly = clean.clone();
    firefly.pixels[77 * 128 + 40] = Rgb::splat(519.6);
    let a = robust_error(&clean, &reference).unwrap();
    let b = robust_error(&firefly, &reference).unwrap();
    assert!(b.rmse > 100.0 * a.rmse, "{a:?} {b:?}");
    assert!(
        (b.median_of_means_rmse / a.median_of_means_rmse - 1.0).abs() < 0.1,
        "{a:?} {b:?}"
    );
    assert_eq!((a.outliers, b.outliers), (0, 1));
    assert_eq!((b.worst.1, b.worst.2), (40, 77));
    // Without outliers the two agree closely.
    assert!((a.median_of_means_rmse / a.rmse - 1.0).abs() < 0.1, "{a:?}");
}
