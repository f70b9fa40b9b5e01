//! The command line's text parsers (`readers::text`): counts, `--samples
//! A..B`, `--size WxH`, `--time` durations. The first byte picks the
//! parser, the rest is the argument; what each accepts is checked against
//! what it promises.
#![no_main]

use libfuzzer_sys::fuzz_target;
use readers::text;

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    let Ok(s) = std::str::from_utf8(rest) else {
        return;
    };
    match which % 6 {
        0 => {
            if let Ok(n) = text::parse_count(s) {
                assert_eq!(n.to_string().parse::<u32>(), Ok(n));
                assert!(s.bytes().all(|b| b.is_ascii_digit()));
            }
        }
        1 => {
            let _ = text::parse_usize_count(s);
        }
        2 => {
            if let Ok(n) = text::parse_u64_count(s) {
                assert!(
                    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()),
                    "{n}"
                );
            }
        }
        3 => {
            if let Ok(r) = text::parse_samples(s) {
                assert!(
                    r.start < r.end && r.end <= reference::scene::MAX_SPP,
                    "{s}: {r:?}"
                );
            }
        }
        4 => {
            if let Ok((w, h)) = text::parse_size(s) {
                assert_eq!(text::parse_size(&format!("{w}x{h}")).ok(), Some((w, h)));
            }
        }
        _ => {
            if let Ok(d) = text::parse_duration(s) {
                assert!(!d.is_zero(), "{s}: a zero duration");
                assert!(d.as_secs_f64() < 1e9, "{s}: {d:?}");
            }
        }
    }
});
