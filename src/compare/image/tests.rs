use super::differences::*;
use super::method::*;
use super::noisy::*;
use super::verdict::*;
use crate::stats;
use glam::DVec3;

fn image(w: u32, h: u32, mean: impl Fn(usize) -> f64, var: f64, spp: u32) -> NoisyImage {
    let n = (w * h) as usize;
    NoisyImage {
        width: w,
        height: h,
        mean: (0..n).map(|i| DVec3::splat(mean(i))).collect(),
        variance: Some(vec![DVec3::splat(var); n]),
        skewness: None,
        spp: Some(spp),
        nonfinite_samples: 0,
        renderer: None,
    }
}

#[test]
fn auto_takes_the_side_with_4x_the_samples_as_the_reference() {
    let with = |spp: Option<u32>| NoisyImage {
        spp,
        ..image(2, 2, |_| 0.5, 1e-4, 1)
    };
    let m = |a, b| Method::for_images(&with(a), &with(b));
    assert_eq!(m(Some(1024), Some(16384)), Some(Method::Reference(Side::B)));
    assert_eq!(m(Some(4096), Some(1024)), Some(Method::Reference(Side::A)));
    assert_eq!(m(Some(1024), Some(4095)), Some(Method::Welch));
    assert_eq!(m(Some(1024), None), Some(Method::Welch));
}

/// Without a sample count, a variance of the mean is not floored at
/// the per-sample 1e-4 (which hid a halved pixel) but only at f32
/// resolution.
#[test]
fn a_side_without_spp_keeps_its_variance_of_the_mean() {
    let mut reference = image(8, 8, |_| 0.05, 1e-9, 16384);
    reference.spp = None;
    let render = image(8, 8, |_| 0.025, 1e-7, 1024);
    let v = compare(&render, &reference, Method::Welch, &TestSettings::default()).unwrap();
    assert!(!v.pixels.passes(), "{}", v.summary());
    assert_eq!(f32_resolution_floor(0.0), 0.0);
    assert!(f32_resolution_floor(1.0) < 1e-12);
}

#[test]
fn identical_images_pass_and_a_shifted_one_fails() {
    let a = image(16, 16, |i| 0.5 + 0.01 * (i % 7) as f64, 1e-4, 100);
    let v = compare(&a, &a, Method::Welch, &TestSettings::default()).unwrap();
    assert!(v.passes(), "{}", v.summary());
    assert_eq!(v.pixels.passed, v.pixels.tests);
    // A shift of 2σ per pixel passes most pixel tests but not the sums.
    let b = image(
        16,
        16,
        |i| 0.5 + 0.01 * (i % 7) as f64 + 2.0 * (2e-4f64).sqrt(),
        1e-4,
        100,
    );
    let v = compare(&b, &a, Method::Welch, &TestSettings::default()).unwrap();
    assert!(v.pixels.passes(), "{}", v.summary());
    assert!(!v.aggregate.passes(), "{}", v.summary());
    assert!(!v.passes());
}

#[test]
fn welch_dof_follows_satterthwaite() {
    let a = image(1, 1, |_| 1.0, 0.04 / 10.0, 10);
    let b = image(1, 1, |_| 1.0, 0.01 / 30.0, 30);
    let d = differences(
        &a,
        &b,
        Method::Welch,
        &TestSettings {
            variance_floor: 0.0,
            ..Default::default()
        },
    )
    .unwrap();
    let (va, vb) = (0.004f64, 0.01 / 30.0);
    // Each side's n_eff − 1, below its n − 1 (a: 9.65 effective
    // samples of its 10, mean 1 and per-sample variance 0.04).
    let dof_a = 10.0 / (1.0 + 9.0 * va) - 1.0;
    let dof_b = 30.0 / (1.0 + 29.0 * vb) - 1.0;
    assert!(dof_a < 9.0 && dof_b < 29.0);
    let expect = (va + vb).powi(2) / (va * va / dof_a + vb * vb / dof_b);
    assert!((d.dof[0].x - expect).abs() < 1e-9 * expect);
}

/// The reference's skewness is carried to the render's budget
/// (`√(n_ref / n)`), the render's own counts too, and a pixel beyond the
/// limit is left out of the per-pixel tests but not out of the sums.
#[test]
fn heavy_tailed_pixels_are_left_to_the_sums() {
    let mut reference = image(8, 8, |_| 0.5, 1e-4 / 16384.0, 16384);
    let mut skew = vec![DVec3::ZERO; 64];
    // 0.2 at 16384 spp is 0.8 at 1024: heavy.
    skew[3] = DVec3::new(0.2, 0.0, 0.0);
    // 0.1 at 16384 spp is 0.4 at 1024: judged.
    skew[4] = DVec3::new(0.1, 0.0, 0.0);
    reference.skewness = Some(skew);
    let mut render = image(8, 8, |_| 0.5, 1e-4 / 1024.0, 1024);
    let mut own = vec![DVec3::ZERO; 64];
    own[9] = DVec3::new(0.0, -0.6, f64::NAN);
    render.skewness = Some(own);
    let settings = TestSettings::default();
    let d = differences(&render, &reference, Method::Reference(Side::B), &settings).unwrap();
    let s = d.skewness.as_ref().unwrap();
    assert!((s[3].x - 0.8).abs() < 1e-12 && (s[4].x - 0.4).abs() < 1e-12);
    assert_eq!((s[9].y, s[9].z), (0.6, f64::INFINITY));
    let v = test_differences(&d, &settings);
    assert_eq!(v.pixels.left_to_sums, 3);
    assert_eq!(v.pixels.tests, 3 * 64 - 3);
    assert!(v.pixels.skewness_known && v.passes(), "{}", v.summary());
    assert!(v.summary().contains("3 tests left to the sums"));
    // A large error in a heavy pixel is not a per-pixel failure, but
    // the sums see it; the same error in a judged pixel fails both.
    for (i, per_pixel_fails) in [(3, false), (4, true)] {
        let mut wrong = render.clone();
        wrong.mean[i].x += 100.0 * (1e-4f64 * (1.0 / 1024.0 + 1.0 / 16384.0)).sqrt();
        let v = compare(&wrong, &reference, Method::Reference(Side::B), &settings).unwrap();
        assert_eq!(
            v.pixels.passed < v.pixels.tests,
            per_pixel_fails,
            "{}",
            v.summary()
        );
        assert!(!v.aggregate.passes(), "{}", v.summary());
    }
    // Without a skewness layer on either side every test is judged.
    render.skewness = None;
    reference.skewness = None;
    let v = compare(&render, &reference, Method::Reference(Side::B), &settings).unwrap();
    assert_eq!((v.pixels.tests, v.pixels.left_to_sums), (3 * 64, 0));
    assert!(v.summary().contains("no skewness layer"));
}

/// The families share the comparison's level: their levels add up to α.
#[test]
fn the_families_share_alpha() {
    let s = TestSettings::default();
    let total: f64 = [Family::Pixels, Family::ImageSums, Family::TileSums]
        .map(|f| s.family_alpha(f))
        .iter()
        .sum();
    assert!((total - s.alpha).abs() < 1e-15);
}

#[test]
fn reference_method_uses_the_reference_noise_and_its_floor() {
    let test = image(2, 2, |_| 1.0, 0.0, 64);
    let reference = image(2, 2, |_| 1.0, 0.5 / 1024.0, 1024);
    let d = differences(
        &test,
        &reference,
        Method::Reference(Side::B),
        &TestSettings::default(),
    )
    .unwrap();
    assert!((d.variance[0].x - 0.5 * (1.0 / 64.0 + 1.0 / 1024.0)).abs() < 1e-15);
    let flat = image(2, 2, |_| 1.0, 0.0, 1024);
    let d = differences(
        &test,
        &flat,
        Method::Reference(Side::B),
        &TestSettings::default(),
    )
    .unwrap();
    assert!((d.variance[0].x - 1e-4 * (1.0 / 64.0 + 1.0 / 1024.0)).abs() < 1e-18);
}

#[test]
fn effective_samples_follow_kish() {
    // Every sample alike: n; every sample 0: none.
    assert_eq!(effective_samples(0.5, 0.0, Some(100)), 100.0);
    assert_eq!(effective_samples(0.0, 0.0, Some(100)), 0.0);
    assert_eq!(effective_samples(0.0, 0.0, None), 0.0);
    assert_eq!(effective_samples(0.5, 0.0, None), f64::INFINITY);
    // k hits of value L in n samples: (kL)² / (k L²) = k.
    let (n, k, l) = (1024.0f64, 5.0f64, 3.0f64);
    let mean = k * l / n;
    let m2 = k * l * l - n * mean * mean;
    let var_of_mean = m2 / (n - 1.0) / n;
    let e = effective_samples(mean, var_of_mean, Some(n as u32));
    assert!((e - k).abs() < 1e-9, "{e}");
    // Without a count, m²/v bounds it from above.
    assert!(effective_samples(mean, var_of_mean, None) >= e);
    assert_eq!(side_dof(Some(1024), e), k - 1.0);
    assert_eq!(side_dof(Some(1024), 0.0), 1.0);
    assert_eq!(side_dof(Some(3), 100.0), 2.0);
    assert_eq!(side_dof(None, f64::INFINITY), f64::INFINITY);
}

/// The MIS-against-BSDF false alarm in miniature: where the BSDF side
/// drew no light (every sample 0) or a few rare samples, and the MIS
/// side did, Welch's `t` was unbounded; such a pixel is now left to
/// the sums, and its variance counts with few degrees of freedom there.
/// A pixel whose sides both have many samples is judged as before, so
/// a real per-pixel bias still fails.
#[test]
fn a_side_with_too_few_effective_samples_is_left_to_the_sums() {
    let n = 1024;
    // Well-sampled pixels: MIS's per-sample variance 0.05, BSDF's 0.3.
    let mut mis = image(8, 8, |_| 0.5, 0.05 / n as f64, n);
    let mut bsdf = image(8, 8, |_| 0.5, 0.3 / n as f64, n);
    for i in [0, 1] {
        mis.mean[i] = DVec3::splat(0.01);
        mis.variance.as_mut().unwrap()[i] = DVec3::splat(1.5e-3 / n as f64);
    }
    // Pixel 0: BSDF saw no light at all. Pixel 1: 3 hits of a light
    // that gives 20 on average (mean 0.0015 where 0.01 is right).
    bsdf.mean[0] = DVec3::ZERO;
    bsdf.variance.as_mut().unwrap()[0] = DVec3::ZERO;
    let (k, l, nf) = (3.0, 0.01 * n as f64 / 20.0, n as f64);
    let few = k * l / nf;
    bsdf.mean[1] = DVec3::splat(few);
    bsdf.variance.as_mut().unwrap()[1] =
        DVec3::splat((k * l * l - nf * few * few) / (nf - 1.0) / nf);
    // Pixel 2: both sides black: judged, and equal.
    mis.mean[2] = DVec3::ZERO;
    mis.variance.as_mut().unwrap()[2] = DVec3::ZERO;
    bsdf.mean[2] = DVec3::ZERO;
    bsdf.variance.as_mut().unwrap()[2] = DVec3::ZERO;
    let settings = TestSettings::default();
    let d = differences(&mis, &bsdf, Method::Welch, &settings).unwrap();
    let e = d.effective_samples.as_ref().unwrap();
    assert!(
        (e[1].x - 3.0).abs() < 1e-9 && e[0].x == 0.0,
        "{:?}",
        &e[..2]
    );
    // Satterthwaite with the BSDF side's 2 degrees of freedom.
    assert!(d.dof[1].x < 20.0, "{}", d.dof[1].x);
    let v = test_differences(&d, &settings);
    assert_eq!(v.pixels.left_few_samples, 6, "{}", v.summary());
    assert_eq!(v.pixels.judged[0], [false; 3]);
    assert_eq!(v.pixels.judged[1], [false; 3]);
    assert_eq!(v.pixels.judged[2], [true; 3]);
    assert!(v
        .summary()
        .contains("6 tests left to the sums (fewer than 4"));
    assert!(v.pixels.passes(), "{}", v.summary());
    // The old rule (each side n − 1 degrees of freedom, every pixel
    // judged): t = 8.0 at pixel 0, p 1.6e-15 at pixel 1 (t = 5.7).
    let old = |i: usize| {
        let va = 1.5e-3 / nf;
        let vb = (bsdf.variance.as_ref().unwrap()[i].x * nf).max(1e-4) / nf;
        (mis.mean[i].x - bsdf.mean[i].x) / (va + vb).sqrt()
    };
    assert!(old(0) > 7.5 && old(1) > 5.5, "{} {}", old(0), old(1));
    assert!(stats::student_t_two_sided_p(old(1), 1000.0) < v.pixels.alpha_per_test);
    assert!(v.pixels.p[1].x > 1e3 * stats::student_t_two_sided_p(old(1), 1000.0));
    // A real local bias on pixels both sides sampled well still fails
    // the per-pixel family.
    let mut biased = mis.clone();
    for i in 8..16 {
        biased.mean[i] *= 1.5;
    }
    let v = compare(&biased, &bsdf, Method::Welch, &settings).unwrap();
    assert!(!v.pixels.passes(), "{}", v.summary());
    // Renders that name different estimators: no pixel is judged
    // alone; the sums still see the local bias.
    let (mut mis_named, mut biased_named, mut bsdf_named) =
        (mis.clone(), biased.clone(), bsdf.clone());
    mis_named.renderer = Some("twintrace/mis".into());
    biased_named.renderer = Some("twintrace/mis".into());
    bsdf_named.renderer = Some("twintrace".into());
    let v = compare(&mis_named, &bsdf_named, Method::Welch, &settings).unwrap();
    assert_eq!((v.pixels.tests, v.pixels.left_to_sums), (0, 192));
    assert!(
        v.passes() && v.summary().contains("none judged alone"),
        "{}",
        v.summary()
    );
    let v = compare(&biased_named, &bsdf_named, Method::Welch, &settings).unwrap();
    assert!(!v.aggregate.passes(), "{}", v.summary());
    // Under the z-test against a reference, the reference's floored
    // per-sample variance is used and no pixel is left for this.
    let v = compare(&mis, &bsdf, Method::Reference(Side::B), &settings).unwrap();
    assert_eq!(v.pixels.left_few_samples, 0);
}

/// The allowance counts pixels, not channels: a pixel whose three
/// channels fail together (one bright sample) is one event. 20x20
/// pixels judge 1,200 tests, an allowance of 3 pixels: three pixels
/// failing in all channels pass (9 failing tests, which the count per
/// test failed), a fourth failing pixel in one channel fails.
#[test]
fn the_allowance_counts_a_pixel_whose_channels_fail_together_once() {
    let reference = image(20, 20, |_| 0.5, 1e-6, 16384);
    let fireflies = |pixels: &[usize], channels: &[usize]| {
        let mut a = image(20, 20, |_| 0.5, 1e-4, 1024);
        for &i in pixels {
            for &c in channels {
                a.mean[i][c] = 5.0;
            }
        }
        compare(
            &a,
            &reference,
            Method::Reference(Side::B),
            &TestSettings::default(),
        )
        .unwrap()
    };
    let v = fireflies(&[3, 150, 377], &[0, 1, 2]);
    assert_eq!(
        (v.pixels.tests, v.pixels.passed, v.pixels.failed_pixels),
        (1200, 1191, 3)
    );
    assert!(v.pixels.passes(), "{}", v.pixels.describe(0.002, 0.5));
    let v = fireflies(&[3, 150, 377, 390], &[1]);
    assert_eq!((v.pixels.passed, v.pixels.failed_pixels), (1196, 4));
    assert!(!v.pixels.passes(), "{}", v.pixels.describe(0.002, 0.5));
}

#[test]
fn nan_fails_its_test_and_sizes_must_match() {
    let a = image(4, 4, |_| 1.0, 1e-3, 10);
    let mut b = a.clone();
    b.mean[5].y = f64::NAN;
    let v = compare(&a, &b, Method::Welch, &TestSettings::default()).unwrap();
    assert_eq!(v.pixels.passed, v.pixels.tests - 1);
    assert!(!v.aggregate.image_passes());
    assert!(compare(
        &a,
        &image(4, 3, |_| 1.0, 1e-3, 10),
        Method::Welch,
        &TestSettings::default()
    )
    .is_err());
}
