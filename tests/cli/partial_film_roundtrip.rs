//! A partial film's EXR encoding round trips: sums → EXR bytes (the
//! writer `twintrace render --samples` uses) → sums (the reader `merge`
//! uses), word for word, for random sums whose words include the extremes
//! (0, 1, 2^31, u32::MAX), and the image layers the sums give come back bit
//! for bit (NaN and infinite layers of absurd sums included).

use proptest::prelude::*;
use reference::film::{FilmSums, PixelSums, PIXEL_WORDS};
use std::io::Cursor;
use twintrace::image_io::{write_exr_with, RenderMetadata};
use twintrace::partial::{Part, RenderKey};

/// A word: one of the extremes half of the time, any word otherwise.
fn word() -> impl Strategy<Value = u32> {
    prop_oneof![
        Just(0u32),
        Just(1),
        Just(1 << 31),
        Just(u32::MAX),
        any::<u32>(),
        any::<u32>(),
        any::<u32>(),
        any::<u32>(),
    ]
}

/// Sums of a film of at most 5x4 pixels; with `range`, each pixel holds
/// the range's samples (`count + rejected = range`), as a part's must.
fn film(range: Option<u32>) -> impl Strategy<Value = FilmSums> {
    (1u32..=5, 1u32..=4).prop_flat_map(move |(w, h)| {
        let n = (w * h) as usize;
        proptest::collection::vec(
            (proptest::collection::vec(word(), PIXEL_WORDS), any::<u32>()),
            n,
        )
        .prop_map(move |pixels| FilmSums {
            width: w,
            height: h,
            pixels: pixels
                .into_iter()
                .map(|(mut words, split)| {
                    if let Some(range) = range {
                        words[0] = split % (range + 1);
                        words[1] = range - words[0];
                    }
                    PixelSums::from_words(&words.try_into().unwrap())
                })
                .collect(),
        })
    })
}

fn part(sums: FilmSums, samples: std::ops::Range<u32>) -> Part {
    Part {
        key: RenderKey {
            scene: "00000000deadbeef".into(),
            settings: format!("{}x{} seed 1", sums.width, sums.height),
            version: "0.1.0".into(),
        },
        metadata: RenderMetadata {
            spp: Some(samples.end - samples.start),
            ..RenderMetadata::default()
        },
        target: Some(samples.start..samples.end),
        samples,
        devices: "cpu".into(),
        sums,
    }
}

fn encode(part: &Part) -> Vec<u8> {
    let mut bytes = Cursor::new(Vec::new());
    write_exr_with(&mut bytes, &part.image(), &part.extras()).unwrap();
    bytes.into_inner()
}

fn layer_bits(layers: [Option<&Vec<glam::Vec3>>; 3]) -> Vec<Option<Vec<u32>>> {
    layers
        .map(|l| {
            l.map(|v| {
                v.iter()
                    .flat_map(|p| p.to_array().map(f32::to_bits))
                    .collect()
            })
        })
        .into()
}

fn config() -> ProptestConfig {
    // 64 cases a property: the three tests take 0.4 s together in a test
    // build (the sums' statistics are the cost); a soak of 20,000
    // (PROPTEST_CASES=20000) passed.
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(64),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn any_sums_come_back_word_for_word(sums in film(None)) {
        let part = part(sums, 0..1);
        let (layers, extras) = readers::exr::read(Cursor::new(encode(&part))).unwrap();
        for i in 0..PIXEL_WORDS {
            let name = twintrace::partial::word_channel(i);
            let want: Vec<u32> = part.sums.pixels.iter().map(|p| p.to_words()[i]).collect();
            prop_assert_eq!(extras.channel(&name), Some(want.as_slice()), "{}", name);
        }
        let image = part.image();
        prop_assert_eq!(
            layer_bits([Some(&layers.mean), layers.variance.as_ref(), layers.skewness.as_ref()]),
            layer_bits([Some(&image.mean), image.variance.as_ref(), image.skewness.as_ref()])
        );
    }

    #[test]
    fn a_part_reads_back_whole(
        (sums, start, len) in (1u32..=1 << 20, 0u32..1 << 23)
            .prop_flat_map(|(len, start)| (film(Some(len)), Just(start), Just(len)))
    ) {
        let part = part(sums, start..start + len);
        let (layers, extras) = readers::exr::read(Cursor::new(encode(&part))).unwrap();
        let back = readers::partial::decode("part.exr", &layers, &extras).unwrap();
        prop_assert_eq!(back.samples, part.samples.clone());
        prop_assert_eq!(&back.sums, &part.sums);
        prop_assert_eq!(
            (back.scene, back.settings, back.version, back.devices),
            (part.key.scene, part.key.settings, part.key.version, part.devices)
        );
    }
}

/// The round trip can fail: a word changed in the bytes is a sum changed
/// (found by the first property) or a part refused (the second).
#[test]
fn a_changed_word_is_caught() {
    // Words of no pattern (an LCG's), so the block does not compress
    // and the EXR stores it as it is.
    let mut words = [0u32; PIXEL_WORDS];
    let mut x = 0x2545_f491u32;
    for w in &mut words[2..] {
        x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *w = x;
    }
    // Word 5 is the high word of R's Σq's top limb: it moves the mean.
    (words[0], words[1], words[5]) = (4, 0, 0x1234_5678);
    let sums = FilmSums {
        width: 1,
        height: 1,
        pixels: vec![PixelSums::from_words(&words)],
    };
    let part = part(sums, 0..4);
    let mut bytes = encode(&part);
    let at = bytes
        .windows(4)
        .position(|w| w == 0x1234_5678u32.to_le_bytes())
        .expect("the word is stored as it is");
    bytes[at + 3] ^= 0x10;
    let (layers, extras) = readers::exr::read(Cursor::new(bytes)).unwrap();
    assert_eq!(
        extras.channel("sums.R.s1.3"),
        Some([0x0234_5678].as_slice())
    );
    let e = readers::partial::decode("part.exr", &layers, &extras).unwrap_err();
    assert!(
        e.to_string().contains("its sums do not give its mean"),
        "{e}"
    );
}
