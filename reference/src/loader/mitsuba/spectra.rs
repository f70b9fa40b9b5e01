//! `wavelength:value` spectra as Mitsuba 3's `rgb` variants read them.
//!
//! Mitsuba's rgb variants turn a spectrum given as a list into linear
//! sRGB once, when the scene is read: the list is a piecewise-linear
//! function of wavelength (zero outside its first and last wavelength),
//! integrated against the CIE 1931 colour-matching functions by a
//! Riemann sum of [`STEPS`] evenly spaced wavelengths over 360–830 nm,
//! each of weight 470 nm / [`STEPS`], divided by [`Y_NORMALIZATION`],
//! and converted from CIE XYZ to linear sRGB ([`XYZ_TO_SRGB`]). A
//! reflectance (any spectrum outside an emitter) is weighted by the D65
//! illuminant on the way, so that a flat spectrum of 1 is (nearly) white,
//! and clamped to [0, 1]; an emitter's spectrum is not weighted (a flat
//! one is the equal-energy illuminant, pinkish in sRGB) and is clamped
//! below at 0. The recipe and its constants were read off Mitsuba 3.9.1's
//! behaviour through its Python package (`mi.cie1931_xyz`, `mi.cie_d65`,
//! `mi.MI_CIE_Y_NORMALIZATION`, and loaded scenes' values); the test
//! `matches_mitsuba` holds this module to values Mitsuba 3.9.1 gave.

use glam::{DMat3, DVec3};

/// Wavelengths of the tables: `SAMPLES` at 5 nm from `CIE_MIN`.
const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const SAMPLES: usize = 95;

/// The sum's wavelengths (Mitsuba 3.9.1's count: with another, its
/// values are not reproduced to 10^-5).
const STEPS: usize = 1000;

/// `1 / ∫ȳ` as Mitsuba 3.9.1 holds it (`mi.MI_CIE_Y_NORMALIZATION`;
/// the 5 nm table's own sum gives 1 / 106.857, 0.1 % less).
const Y_NORMALIZATION: f64 = 0.009_367_658_735_689_113;

/// D65's scale that makes `∫ D65 ȳ` match `∫ ȳ` (`mi.MI_CIE_D65_NORMALIZATION`).
const D65_NORMALIZATION: f64 = 0.010_101_273_599_490_354;

/// CIE XYZ to linear sRGB (primaries and D65 white of IEC 61966-2-1),
/// rows as written; the matrix Mitsuba's `xyz_to_srgb` uses.
#[rustfmt::skip]
const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [ 3.240479, -1.537150, -0.498535],
    [-0.969256,  1.875991,  0.041556],
    [ 0.055648, -0.204043,  1.057311],
];

/// What a spectrum feeds, which decides its weighting and clamping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumUse {
    /// A reflectance (or any other value outside an emitter): weighted by
    /// D65, clamped to [0, 1].
    Reflectance,
    /// An emitter's radiance or intensity: unweighted, clamped below at 0.
    Emission,
}

/// The result of [`to_srgb`]: the colour, and whether it was clamped
/// (outside sRGB's gamut, or above 1 for a reflectance), which Mitsuba
/// warns of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Converted {
    pub rgb: DVec3,
    pub clamped: bool,
}

/// Linear sRGB of the piecewise-linear spectrum through `pairs`
/// (wavelength in nm, increasing; at least two), as Mitsuba's rgb
/// variants make of it.
pub fn to_srgb(pairs: &[(f64, f64)], usage: SpectrumUse) -> Converted {
    debug_assert!(pairs.len() >= 2);
    let (first, last) = (pairs[0].0, pairs[pairs.len() - 1].0);
    let mut xyz = DVec3::ZERO;
    let mut segment = 0;
    for i in 0..STEPS {
        let x = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if x < first || x > last {
            continue;
        }
        while segment + 2 < pairs.len() && x > pairs[segment + 1].0 {
            segment += 1;
        }
        let ((x0, y0), (x1, y1)) = (pairs[segment], pairs[segment + 1]);
        let mut y = y0 + (y1 - y0) * ((x - x0) / (x1 - x0));
        let (cmf, d65) = cie(x);
        if usage == SpectrumUse::Reflectance {
            y *= d65 * D65_NORMALIZATION;
        }
        xyz += cmf * y;
    }
    xyz *= (CIE_MAX - CIE_MIN) / STEPS as f64 * Y_NORMALIZATION;
    let m = DMat3::from_cols_array_2d(&XYZ_TO_SRGB).transpose();
    let rgb = m * xyz;
    let clamped_rgb = match usage {
        SpectrumUse::Reflectance => rgb.clamp(DVec3::ZERO, DVec3::ONE),
        SpectrumUse::Emission => rgb.max(DVec3::ZERO),
    };
    Converted {
        rgb: clamped_rgb,
        clamped: clamped_rgb != rgb,
    }
}

/// The colour-matching functions and D65 at wavelength `x` (nm), linear
/// between the table's wavelengths, zero outside them.
fn cie(x: f64) -> (DVec3, f64) {
    if !(CIE_MIN..=CIE_MAX).contains(&x) {
        return (DVec3::ZERO, 0.0);
    }
    let t = (x - CIE_MIN) / 5.0;
    let i = (t.floor() as usize).min(SAMPLES - 2);
    let f = t - i as f64;
    let row = |k: usize| {
        let r = CIE_TABLE[k];
        (DVec3::new(r[0], r[1], r[2]), r[3])
    };
    let ((c0, d0), (c1, d1)) = (row(i), row(i + 1));
    (c0.lerp(c1, f), d0 + (d1 - d0) * f)
}

/// The CIE 1931 2° standard observer's colour-matching functions x̄, ȳ, z̄
/// and the CIE standard illuminant D65 (relative, 100 at 560 nm), at
/// 5 nm from 360 to 830 nm: the CIE's published tables (CIE 015:2018),
/// at the precision Mitsuba 3's rgb variants hold them.
#[rustfmt::skip]
const CIE_TABLE: [[f64; 4]; SAMPLES] = [
    [0.0001299, 3.917e-06, 0.0006061, 46.6383], // 360 nm
    [0.0002321, 6.965e-06, 0.001086, 49.3637], // 365 nm
    [0.0004149, 1.239e-05, 0.001946, 52.0891], // 370 nm
    [0.0007416, 2.202e-05, 0.003486, 51.0323], // 375 nm
    [0.001368, 3.9e-05, 0.00645, 49.9755], // 380 nm
    [0.002236, 6.4e-05, 0.01055, 52.3118], // 385 nm
    [0.004243, 0.00012, 0.02005, 54.6482], // 390 nm
    [0.00765, 0.000217, 0.03621, 68.7015], // 395 nm
    [0.01431, 0.000396, 0.06785, 82.7549], // 400 nm
    [0.02319, 0.00064, 0.1102, 87.1204], // 405 nm
    [0.04351, 0.00121, 0.2074, 91.486], // 410 nm
    [0.07763, 0.00218, 0.3713, 92.4589], // 415 nm
    [0.13438, 0.004, 0.6456, 93.4318], // 420 nm
    [0.21477, 0.0073, 1.03905, 90.057], // 425 nm
    [0.2839, 0.0116, 1.3856, 86.6823], // 430 nm
    [0.3285, 0.01684, 1.62296, 95.7736], // 435 nm
    [0.34828, 0.023, 1.74706, 104.865], // 440 nm
    [0.34806, 0.0298, 1.7826, 110.936], // 445 nm
    [0.3362, 0.038, 1.77211, 117.008], // 450 nm
    [0.3187, 0.048, 1.7441, 117.41], // 455 nm
    [0.2908, 0.06, 1.6692, 117.812], // 460 nm
    [0.2511, 0.0739, 1.5281, 116.336], // 465 nm
    [0.19536, 0.09098, 1.28764, 114.861], // 470 nm
    [0.1421, 0.1126, 1.0419, 115.392], // 475 nm
    [0.09564, 0.13902, 0.81295, 115.923], // 480 nm
    [0.05795, 0.1693, 0.6162, 112.367], // 485 nm
    [0.03201, 0.20802, 0.46518, 108.811], // 490 nm
    [0.0147, 0.2586, 0.3533, 109.082], // 495 nm
    [0.0049, 0.323, 0.272, 109.354], // 500 nm
    [0.0024, 0.4073, 0.2123, 108.578], // 505 nm
    [0.0093, 0.503, 0.1582, 107.802], // 510 nm
    [0.0291, 0.6082, 0.1117, 106.296], // 515 nm
    [0.06327, 0.71, 0.07825, 104.79], // 520 nm
    [0.1096, 0.7932, 0.05725, 106.239], // 525 nm
    [0.1655, 0.862, 0.04216, 107.689], // 530 nm
    [0.22575, 0.91485, 0.02984, 106.047], // 535 nm
    [0.2904, 0.954, 0.0203, 104.405], // 540 nm
    [0.3597, 0.9803, 0.0134, 104.225], // 545 nm
    [0.43345, 0.99495, 0.00875, 104.046], // 550 nm
    [0.51205, 1.0, 0.00575, 102.023], // 555 nm
    [0.5945, 0.995, 0.0039, 100.0], // 560 nm
    [0.6784, 0.9786, 0.00275, 98.1671], // 565 nm
    [0.7621, 0.952, 0.0021, 96.3342], // 570 nm
    [0.8425, 0.9154, 0.0018, 96.0611], // 575 nm
    [0.9163, 0.87, 0.00165, 95.788], // 580 nm
    [0.9786, 0.8163, 0.0014, 92.2368], // 585 nm
    [1.0263, 0.757, 0.0011, 88.6856], // 590 nm
    [1.0567, 0.6949, 0.001, 89.3459], // 595 nm
    [1.0622, 0.631, 0.0008, 90.0062], // 600 nm
    [1.0456, 0.5668, 0.0006, 89.8026], // 605 nm
    [1.0026, 0.503, 0.00034, 89.5991], // 610 nm
    [0.9384, 0.4412, 0.00024, 88.6489], // 615 nm
    [0.85445, 0.381, 0.00019, 87.6987], // 620 nm
    [0.7514, 0.321, 0.0001, 85.4936], // 625 nm
    [0.6424, 0.265, 5e-05, 83.2886], // 630 nm
    [0.5419, 0.217, 3e-05, 83.4939], // 635 nm
    [0.4479, 0.175, 2e-05, 83.6992], // 640 nm
    [0.3608, 0.1382, 1e-05, 81.863], // 645 nm
    [0.2835, 0.107, 0.0, 80.0268], // 650 nm
    [0.2187, 0.0816, 0.0, 80.1207], // 655 nm
    [0.1649, 0.061, 0.0, 80.2146], // 660 nm
    [0.1212, 0.04458, 0.0, 81.2462], // 665 nm
    [0.0874, 0.032, 0.0, 82.2778], // 670 nm
    [0.0636, 0.0232, 0.0, 80.281], // 675 nm
    [0.04677, 0.017, 0.0, 78.2842], // 680 nm
    [0.0329, 0.01192, 0.0, 74.0027], // 685 nm
    [0.0227, 0.00821, 0.0, 69.7213], // 690 nm
    [0.01584, 0.005723, 0.0, 70.6652], // 695 nm
    [0.0113592, 0.004102, 0.0, 71.6091], // 700 nm
    [0.00811092, 0.002929, 0.0, 72.979], // 705 nm
    [0.00579035, 0.002091, 0.0, 74.349], // 710 nm
    [0.00410946, 0.001484, 0.0, 67.9765], // 715 nm
    [0.00289933, 0.001047, 0.0, 61.604], // 720 nm
    [0.00204919, 0.00074, 0.0, 65.7448], // 725 nm
    [0.00143997, 0.00052, 0.0, 69.8856], // 730 nm
    [0.000999949, 0.0003611, 0.0, 72.4863], // 735 nm
    [0.000690079, 0.0002492, 0.0, 75.087], // 740 nm
    [0.000476021, 0.0001719, 0.0, 69.3398], // 745 nm
    [0.000332301, 0.00012, 0.0, 63.5927], // 750 nm
    [0.000234826, 8.48e-05, 0.0, 55.0054], // 755 nm
    [0.00016615, 6e-05, 0.0, 46.4182], // 760 nm
    [0.000117413, 4.24e-05, 0.0, 56.6118], // 765 nm
    [8.30753e-05, 3e-05, 0.0, 66.8054], // 770 nm
    [5.87065e-05, 2.12e-05, 0.0, 65.0941], // 775 nm
    [4.15099e-05, 1.499e-05, 0.0, 63.3828], // 780 nm
    [2.93533e-05, 1.06e-05, 0.0, 63.8434], // 785 nm
    [2.06738e-05, 7.4657e-06, 0.0, 64.304], // 790 nm
    [1.45598e-05, 5.2578e-06, 0.0, 61.8779], // 795 nm
    [1.0254e-05, 3.7029e-06, 0.0, 59.4519], // 800 nm
    [7.22146e-06, 2.6078e-06, 0.0, 55.7054], // 805 nm
    [5.08587e-06, 1.8366e-06, 0.0, 51.959], // 810 nm
    [3.58165e-06, 1.2934e-06, 0.0, 54.6998], // 815 nm
    [2.52252e-06, 9.1093e-07, 0.0, 57.4406], // 820 nm
    [1.77651e-06, 6.4153e-07, 0.0, 58.8765], // 825 nm
    [1.25114e-06, 4.5181e-07, 0.0, 60.3125], // 830 nm
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Values Mitsuba 3.9.1 (`scalar_rgb`) gave for these spectra, read
    /// back with `mi.traverse` from a loaded scene (a diffuse
    /// reflectance, and an area emitter's radiance); printed to 6 digits.
    #[test]
    fn matches_mitsuba() {
        use SpectrumUse::*;
        // (spectrum, use, Mitsuba's rgb, whether it clamped)
        type Case<'a> = (&'a [(f64, f64)], SpectrumUse, [f64; 3], bool);
        let cases: [Case; 7] = [
            (
                &[(400.0, 0.78), (500.0, 0.78), (600.0, 0.78), (700.0, 0.78)],
                Reflectance,
                [0.776367, 0.77981, 0.776029],
                false,
            ),
            (
                &[(400.0, 0.78), (500.0, 0.78), (600.0, 0.78), (700.0, 0.78)],
                Emission,
                [0.935761, 0.740626, 0.704686],
                false,
            ),
            (
                &[(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)],
                Emission,
                [20.7108, 10.8546, 2.77115],
                false,
            ),
            (
                &[(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)],
                Reflectance,
                [1.0, 1.0, 1.0],
                true,
            ),
            (
                &[(550.0, 1.0), (560.0, 1.0)],
                Emission,
                [0.0122891, 0.133081, 0.0],
                true,
            ),
            (
                &[(360.0, 1.0), (830.0, 1.0)],
                Reflectance,
                [0.998985, 0.998874, 0.998802],
                false,
            ),
            (
                &[(300.0, 1.0), (900.0, 1.0)],
                Emission,
                [1.20488, 0.948228, 0.909267],
                false,
            ),
        ];
        for (pairs, usage, want, clamped) in cases {
            let got = to_srgb(pairs, usage);
            for k in 0..3 {
                // Mitsuba's figures are printed to 6 significant digits.
                let tol = 1e-5 * want[k].abs().max(1.0);
                assert!(
                    (got.rgb[k] - want[k]).abs() <= tol,
                    "{pairs:?} {usage:?}: {} against Mitsuba's {want:?}",
                    got.rgb
                );
            }
            assert_eq!(got.clamped, clamped, "{pairs:?} {usage:?}");
        }
    }

    #[test]
    fn tables_are_the_cie_standard() {
        // CIE 015:2018: ȳ peaks at 1 at 555 nm; x̄(600) = 1.0622; D65 is
        // 100 at 560 nm; nothing is read outside 360–830 nm.
        assert_eq!(cie(555.0).0.y, 1.0);
        assert_eq!(cie(600.0).0.x, 1.0622);
        assert_eq!(cie(560.0).1, 100.0);
        assert_eq!(cie(359.0), (DVec3::ZERO, 0.0));
        assert_eq!(cie(831.0), (DVec3::ZERO, 0.0));
        let mid = cie(602.5).0;
        assert!((mid.x - 0.5 * (1.0622 + 1.0456)).abs() < 1e-12);
    }
}
