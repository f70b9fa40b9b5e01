//! `twintrace merge`'s reading of a partial film: the EXR
//! (`readers::exr::read`), then its key, range and sums checked whole
//! (`readers::partial::decode`, behind `twintrace::partial::Part::read`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok((layers, extras)) = readers::exr::read(std::io::Cursor::new(data)) {
        let _ = readers::partial::decode("part.exr", &layers, &extras);
    }
});
