//! The host memory a render needs, against what the machine has: an image
//! too large for this machine is refused in one line before the render,
//! rather than ending in the kernel's out-of-memory killer part way.
//!
//! The figures are peak resident bytes a pixel, measured (release build,
//! `/usr/bin/time -f %M`), rounded up; a render's fixed part (the scene,
//! the kernels, the driver) is left out.

/// A CPU render: `cornell`, 1 spp, depth 1, peaked at 0.70 GB at 1024²
/// and 2.76 GB at 2048² (dev machine, 2026-11-27): 656 bytes a pixel
/// between the two (the film's exact sums and moments, the image's
/// layers and the outputs).
pub const CPU_BYTES_PER_PIXEL: u64 = 700;

/// A GPU render, whose film stays on the device: `rtow-final`
/// 7680x4320, 1 spp, peaked at 1.84 GB on the H100 (2026-11-27): 55.5
/// bytes a pixel, driver included (the layers read back, 36 bytes a
/// pixel, and the outputs written from them).
pub const GPU_BYTES_PER_PIXEL: u64 = 64;

/// A GPU film on the device: 224 bytes a pixel (the sums' 56 words),
/// which a software adapter (lavapipe) keeps in host memory.
pub const DEVICE_FILM_BYTES_PER_PIXEL: u64 = gpu::records::FILM_PIXEL_WORDS as u64 * 4;

/// A render that writes its film's exact sums (a partial film:
/// `--samples`, `--checkpoint`, `--resume`): the sums, 224 bytes a pixel,
/// and the EXR channels written from them, as many again.
pub const SUMS_BYTES_PER_PIXEL: u64 = 448;

/// AOVs (`--aov`): 48 bytes a pixel read back, and as many in the EXR's
/// float channels.
pub const AOV_BYTES_PER_PIXEL: u64 = 96;

/// Caps, in bytes, the memory a render may count on (below what the
/// machine has; the tests make a large image's refusal certain with it).
pub const LIMIT_VAR: &str = "TWINTRACE_MEMORY_LIMIT";

/// What the kernel says is available for new allocations without
/// swapping (`MemAvailable` of /proc/meminfo), in bytes, capped by
/// [`LIMIT_VAR`]; `None` where neither says (another system, no cap), and
/// then nothing is checked. A cap that is not a whole number of bytes is
/// an error naming it.
pub fn available() -> Result<Option<u64>, String> {
    let machine = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| mem_available(&text));
    let cap = match std::env::var(LIMIT_VAR) {
        Ok(v) => Some(v.trim().parse::<u64>().map_err(|_| {
            format!("{LIMIT_VAR}={v:?}: the memory limit must be a whole number of bytes")
        })?),
        Err(_) => None,
    };
    Ok(match (machine, cap) {
        (Some(m), Some(c)) => Some(m.min(c)),
        (m, c) => m.or(c),
    })
}

/// `MemAvailable` of a /proc/meminfo text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let kib: u64 = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(kib.checked_mul(1024)?)
}

/// Fails, in one line, where `pixels` at `bytes_per_pixel` need more than
/// `available` bytes (`None`: unknown, nothing checked). `what` names the
/// render (`a 15360x8640 render on the cpu`).
pub fn check(
    what: &str,
    pixels: u64,
    bytes_per_pixel: u64,
    available: Option<u64>,
) -> Result<(), String> {
    let Some(available) = available else {
        return Ok(());
    };
    let needed = pixels.saturating_mul(bytes_per_pixel);
    if needed <= available {
        return Ok(());
    }
    let gb = |b: u64| b as f64 / 1e9;
    Err(format!(
        "{what} needs about {:.1} GB of memory ({bytes_per_pixel} bytes a pixel), and this machine has {:.1} GB available; render a smaller image, or on a machine with more memory",
        gb(needed),
        gb(available)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_is_read_in_bytes() {
        let text =
            "MemTotal:       24000000 kB\nMemFree:         1000 kB\nMemAvailable:   20000000 kB\n";
        assert_eq!(mem_available(text), Some(20_000_000 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
        assert_eq!(mem_available("MemAvailable: x kB\n"), None);
        assert_eq!(mem_available("MemAvailable: 5 MB\n"), None);
    }

    #[test]
    fn a_render_past_what_is_available_is_refused_in_one_line() {
        let pixels = 15360 * 8640;
        assert!(check("a render", pixels, 64, Some(10_000_000_000)).is_ok());
        let e = check(
            "a 15360x8640 render on the cpu",
            pixels,
            700,
            Some(20_000_000_000),
        )
        .unwrap_err();
        assert!(
            e.starts_with("a 15360x8640 render on the cpu needs about 92.9 GB of memory (700 bytes a pixel), and this machine has 20.0 GB available")
                && !e.contains('\n'),
            "{e}"
        );
        assert!(check("a render", u64::MAX, 700, Some(1)).is_err());
        assert!(check("a render", pixels, 700, None).is_ok());
    }
}
