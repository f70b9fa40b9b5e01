//! The EXR reader of `twintrace diff` and of every render read back
//! (`readers::exr::read`, behind `twintrace::image_io::read_exr`), from
//! bytes in memory.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = readers::exr::read(std::io::Cursor::new(data));
});
