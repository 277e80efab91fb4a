//! Image metrics on small hand-made images with known answers.

use vlf::metrics::compare;
use vlf::render::Frame;

fn frame(w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> Frame {
    let pixels = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let c = f(x, y);
            [c[0], c[1], c[2], 1.0]
        });
    Frame {
        width: w,
        height: h,
        pixels: pixels.collect(),
    }
}

#[test]
fn identical_images_have_zero_error() {
    let a = frame(16, 16, |x, y| [x as f32 / 16.0, y as f32 / 16.0, 0.5]);
    let c = compare(&a, &a).unwrap();
    assert_eq!(
        (c.mse, c.rmse, c.rel_mse, c.max_abs, c.display_mse),
        (0.0, 0.0, 0.0, 0.0, 0.0)
    );
    assert!(c.flip_mean.abs() < 1e-6);
}

#[test]
fn a_constant_offset_gives_the_analytic_values() {
    // reference 0.5 everywhere, test 0.6: every channel off by 0.1
    let reference = frame(8, 8, |_, _| [0.5; 3]);
    let test = frame(8, 8, |_, _| [0.6; 3]);
    let c = compare(&test, &reference).unwrap();
    // the inputs are f32: 0.6 - 0.5 is 0.1 to about 1e-7
    assert!((c.mse - 0.01).abs() < 1e-8, "{}", c.mse);
    assert!((c.rmse - 0.1).abs() < 1e-7);
    assert!(
        (c.rel_mse - 0.01 / (0.25 + 0.01)).abs() < 1e-7,
        "{}",
        c.rel_mse
    );
    assert!((c.max_abs - 0.1).abs() < 1e-6);
    // display: sRGB(0.6) - sRGB(0.5), squared
    let s = |x: f64| 1.055 * x.powf(1.0 / 2.4) - 0.055;
    let expected = (s(0.6) - s(0.5)).powi(2);
    assert!(
        (c.display_mse - expected).abs() < 1e-6,
        "{} vs {expected}",
        c.display_mse
    );
    assert!(c.flip_mean > 0.0);
    assert!((c.mean_ratio - 1.2).abs() < 1e-6, "{}", c.mean_ratio);
    assert!((c.mean_ratio - 1.0).abs() > 0.1 && c.rel_mse > 0.0);
}

/// The mean ratio is over the pixels compared and the three channels: a test image bright on
/// one half and dark on the other by as much has the reference's mean; a mask that keeps the
/// bright half alone gives that half's ratio.
#[test]
fn the_mean_ratio_weighs_every_pixel_and_channel_and_follows_the_mask() {
    let reference = frame(8, 8, |_, _| [0.5, 0.25, 1.0]);
    let test = frame(8, 8, |x, _| {
        let k = if x < 4 { 1.5 } else { 0.5 };
        [0.5 * k, 0.25 * k, 1.0 * k]
    });
    let c = compare(&test, &reference).unwrap();
    assert!((c.mean_ratio - 1.0).abs() < 1e-6, "{}", c.mean_ratio);
    let left: Vec<bool> = (0..64).map(|i| i % 8 < 4).collect();
    let masked = vlf::metrics::compare_where(&test, &reference, Some(&left)).unwrap();
    assert!(
        (masked.mean_ratio - 1.5).abs() < 1e-6,
        "{}",
        masked.mean_ratio
    );
}

#[test]
fn one_bad_pixel_is_averaged_over_all_and_is_the_max() {
    let reference = frame(10, 10, |_, _| [1.0; 3]);
    let test = frame(10, 10, |x, y| {
        if (x, y) == (3, 4) {
            [3.0, 1.0, 1.0]
        } else {
            [1.0; 3]
        }
    });
    let c = compare(&test, &reference).unwrap();
    // one channel of one pixel off by 2: MSE = 4 / 300
    assert!((c.mse - 4.0 / 300.0).abs() < 1e-9);
    assert!((c.rel_mse - 4.0 / 1.01 / 300.0).abs() < 1e-9);
    assert!((c.max_abs - 2.0).abs() < 1e-9);
    // above 1 both clamp to white: no display error
    assert_eq!(c.display_mse, 0.0);
}

#[test]
fn black_against_white_is_the_largest_flip_error() {
    let c = compare(
        &frame(32, 32, |_, _| [0.0; 3]),
        &frame(32, 32, |_, _| [1.0; 3]),
    )
    .unwrap();
    assert!(c.flip_mean > 0.9, "FLIP {}", c.flip_mean);
    let small = compare(
        &frame(32, 32, |_, _| [0.5; 3]),
        &frame(32, 32, |_, _| [0.52; 3]),
    )
    .unwrap();
    assert!(small.flip_mean < 0.1, "FLIP {}", small.flip_mean);
}

#[test]
fn sizes_must_match() {
    let e = compare(&frame(4, 4, |_, _| [0.0; 3]), &frame(4, 5, |_, _| [0.0; 3]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("4x4") && e.contains("4x5"), "{e}");
}
