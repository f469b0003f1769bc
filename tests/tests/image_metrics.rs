//! Image comparisons never pass by accident: every metric, the z-test and the mean of
//! several renders refuse an image with a NaN or infinite pixel (or a negative variance),
//! saying which image and how many pixels, instead of returning a NaN that no threshold
//! catches.

use lobe_renderer::Rgb;
use lobe_renderer::compare::{mean_and_variance, metrics, pixel_errors, z_test};
use lobe_renderer::film::Image;

fn image(v: f32) -> Image {
    let mut i = Image::new(16, 16);
    i.pixels.iter_mut().for_each(|p| *p = Rgb::splat(v));
    i.variance.iter_mut().for_each(|p| *p = Rgb::splat(1e-4));
    i
}

fn with_bad_pixels(mut i: Image, bad: &[(usize, f32)]) -> Image {
    for &(k, v) in bad {
        i.pixels[k].g = v;
    }
    i
}

#[test]
fn non_finite_pixels_are_refused_with_their_count() {
    let good = image(0.5);
    let nan = with_bad_pixels(
        image(0.5),
        &[(3, f32::NAN), (7, f32::INFINITY), (9, f32::NAN)],
    );
    for (test, reference, which) in [
        (&nan, &good, "the test image"),
        (&good, &nan, "the reference image"),
    ] {
        let e = pixel_errors(test, reference).unwrap_err().to_string();
        assert!(
            e.contains(which) && e.contains("3 of 256 pixels are non-finite"),
            "{e}"
        );
        let e = metrics(test, reference, 0.0).unwrap_err().to_string();
        assert!(e.contains(which), "{e}");
        let e = z_test(test, reference, 0.01).unwrap_err().to_string();
        assert!(e.contains(which), "{e}");
    }
    let e = mean_and_variance(&[good.clone(), nan.clone()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("render 2") && e.contains("3 of 256"), "{e}");
    // Finite images still compare.
    assert!(metrics(&good, &image(0.4), 0.0).unwrap().0.rmse > 0.09);
}

#[test]
fn the_z_test_refuses_bad_variances_and_rates() {
    let good = image(0.5);
    let mut nan_var = image(0.5);
    nan_var.variance[0] = Rgb::splat(f32::NAN);
    let e = z_test(&nan_var, &good, 0.01).unwrap_err().to_string();
    assert!(
        e.contains("the test image's variance") && e.contains("1 of 256"),
        "{e}"
    );
    let mut negative = image(0.5);
    negative.variance[4].b = -1.0;
    let e = z_test(&good, &negative, 0.01).unwrap_err().to_string();
    assert!(
        e.contains("reference image's variance") && e.contains("negative"),
        "{e}"
    );
    for alpha in [0.0, 1.0, f64::NAN] {
        assert!(z_test(&good, &good, alpha).is_err(), "alpha {alpha}");
    }
    assert!(z_test(&good, &good, 0.01).unwrap().passed());
}
