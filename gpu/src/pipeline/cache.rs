//! What the device's caches hold of the kernels `pipeline` builds, and
//! the driver's pipeline cache on disk: the modules and pipelines kept
//! ([`Caches`], each kept while among the most recently used, [`Lru`]),
//! the time spent building them ([`CompileStats`]), and the cache file
//! ([`DiskCache`] in [`cache_dir`]: a header naming the adapter, driver
//! and twintrace version, a checksum of the data). Nothing here builds a
//! kernel or needs an open device's context: the context holds its
//! device's caches, and `pipeline` looks kernels up in them and fills them.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Shader modules a device keeps: a module holds naga's form of a whole
/// program (megabytes for the render program), and the tests compile
/// many edited programs once each.
const MODULES_KEPT: usize = 4;

/// Pipelines a hardware device keeps: 64 hold the oracle kernels the
/// variant gates of `selftest` build for every scene and estimator (the
/// H200's `selftest` peaked at 1.1 GB of host memory with them).
const PIPELINES_KEPT: usize = 64;

/// Pipelines a software device keeps: on lavapipe a compiled pipeline
/// holds its machine code, up to hundreds of megabytes for the render
/// kernels, and the test suite's one device, keeping 64, grew past 20 GB.
/// Keeping 16 it peaks at 4.0 GB (the integration tests on the 2-core
/// development machine, `/usr/bin/time -v`), and 16 hold a wave gate's
/// kernels of one variant (the sorted wavefront's seven and the
/// megakernel) while a second test runs beside it: keeping 4, the wave
/// gate rebuilt every kernel for every scene (618 pipelines, 108 s alone;
/// 40 pipelines and 18 s keeping 16).
const PIPELINES_KEPT_SOFTWARE: usize = 16;

/// A map that keeps its `capacity` most recently used entries.
pub(crate) struct Lru<K, V> {
    capacity: usize,
    clock: u64,
    entries: HashMap<K, (V, u64)>,
}

impl<K: std::hash::Hash + Eq + Clone, V: Clone> Lru<K, V> {
    fn new(capacity: usize) -> Self {
        Lru {
            capacity,
            clock: 0,
            entries: HashMap::new(),
        }
    }

    pub(super) fn get<Q>(&mut self, key: &Q) -> Option<V>
    where
        K: std::borrow::Borrow<Q>,
        Q: std::hash::Hash + Eq + ?Sized,
    {
        self.clock += 1;
        let now = self.clock;
        self.entries.get_mut(key).map(|(v, used)| {
            *used = now;
            v.clone()
        })
    }

    pub(super) fn insert(&mut self, key: K, value: V) {
        self.clock += 1;
        if !self.entries.contains_key(&key) && self.entries.len() >= self.capacity {
            let oldest = self
                .entries
                .iter()
                .min_by_key(|(_, (_, used))| *used)
                .map(|(k, _)| k.clone());
            if let Some(k) = oldest {
                self.entries.remove(&k);
            }
        }
        self.entries.insert(key, (value, self.clock));
    }

    /// The keys, the most recently used first.
    pub(super) fn keys_by_use(&self) -> Vec<&K> {
        let mut keys: Vec<(&K, u64)> = self.entries.iter().map(|(k, (_, t))| (k, *t)).collect();
        keys.sort_by_key(|(_, t)| std::cmp::Reverse(*t));
        keys.into_iter().map(|(k, _)| k).collect()
    }

    pub(super) fn remove<Q>(&mut self, key: &Q)
    where
        K: std::borrow::Borrow<Q>,
        Q: std::hash::Hash + Eq + ?Sized,
    {
        self.entries.remove(key);
    }

    fn len(&self) -> usize {
        self.entries.len()
    }
}

/// A module being built or built: threads that need the same program
/// wait for the one building it; other programs build meanwhile.
pub(super) type ModuleCell = std::sync::Arc<std::sync::OnceLock<wgpu::ShaderModule>>;

/// Held by the thread building a set of pipelines.
pub(super) type BuildLock = std::sync::Arc<Mutex<()>>;

/// The per-device caches of modules, layouts and pipelines.
pub(crate) struct Caches {
    /// Keyed by the runtime checks and the program's text.
    pub(super) modules: Mutex<Lru<(crate::Checks, String), ModuleCell>>,
    pub(super) layouts: Mutex<HashMap<&'static str, wgpu::BindGroupLayout>>,
    pub(super) pipelines: Mutex<Lru<PipelineKey, wgpu::ComputePipeline>>,
    /// The pipelines being built, by their keys: a thread that needs the
    /// same ones waits for the thread building them and then finds them
    /// in [`Caches::pipelines`] (the gates render many scenes with one
    /// kernel at once; each would otherwise compile it).
    pub(super) building: Mutex<HashMap<Vec<PipelineKey>, BuildLock>>,
    /// Time spent building modules and pipelines, summed over threads.
    pub(super) module_nanos: AtomicU64,
    pub(super) pipeline_nanos: AtomicU64,
}

/// What a device has compiled: modules and pipelines built and the time
/// spent building them, summed over threads (so above the wall time where
/// several threads compiled at once).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CompileStats {
    pub pipelines: u64,
    pub module_time: std::time::Duration,
    pub pipeline_time: std::time::Duration,
}

impl Caches {
    /// The caches of a device, a software one (lavapipe) where `software`.
    pub(crate) fn new(software: bool) -> Self {
        let pipelines = if software {
            PIPELINES_KEPT_SOFTWARE
        } else {
            PIPELINES_KEPT
        };
        Caches {
            modules: Mutex::new(Lru::new(MODULES_KEPT)),
            layouts: Mutex::new(HashMap::new()),
            pipelines: Mutex::new(Lru::new(pipelines)),
            building: Mutex::new(HashMap::new()),
            module_nanos: AtomicU64::new(0),
            pipeline_nanos: AtomicU64::new(0),
        }
    }

    /// Time spent building modules and pipelines.
    pub(crate) fn times(&self) -> (std::time::Duration, std::time::Duration) {
        let d = |a: &AtomicU64| std::time::Duration::from_nanos(a.load(Ordering::Relaxed));
        (d(&self.module_nanos), d(&self.pipeline_nanos))
    }

    /// Modules and pipelines held.
    pub(crate) fn held(&self) -> (usize, usize) {
        let m = self.modules.lock().unwrap_or_else(|p| p.into_inner()).len();
        let p = self
            .pipelines
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .len();
        (m, p)
    }
}

/// What a pipeline is built from: the module's runtime checks, the
/// program (by its text), the entry
/// point, the constants (by their bits) and the layouts (by identity).
#[derive(Clone, PartialEq, Eq, Hash)]
pub(super) struct PipelineKey {
    pub(super) checks: crate::Checks,
    pub(super) source: String,
    pub(super) entry: String,
    pub(super) constants: Vec<(String, u64)>,
    pub(super) layouts: Vec<wgpu::BindGroupLayout>,
}

/// The folder of the on-disk pipeline cache: `$TWINTRACE_CACHE_DIR` (set
/// and empty: no cache on disk), else `$XDG_CACHE_HOME/twintrace`, else
/// `$HOME/.cache/twintrace`.
pub fn cache_dir() -> Option<PathBuf> {
    match std::env::var_os("TWINTRACE_CACHE_DIR") {
        Some(d) if d.is_empty() => None,
        Some(d) => Some(PathBuf::from(d)),
        None => std::env::var_os("XDG_CACHE_HOME")
            .filter(|d| !d.is_empty())
            .map(|d| PathBuf::from(d).join("twintrace"))
            .or_else(|| {
                std::env::var_os("HOME")
                    .filter(|d| !d.is_empty())
                    .map(|h| PathBuf::from(h).join(".cache").join("twintrace"))
            }),
    }
}

/// The driver's pipeline cache of one device and the file it is kept in.
pub(crate) struct DiskCache {
    pub(crate) cache: wgpu::PipelineCache,
    path: PathBuf,
    /// The header's identity line: adapter, driver, twintrace version.
    identity: String,
    /// Bytes of cache data loaded when the device opened (0: none).
    pub(crate) loaded: usize,
    /// The loaded data's checksum: a run that added nothing to the cache
    /// does not write it again.
    loaded_checksum: Option<u64>,
}

/// The first bytes of a cache file.
const MAGIC: &[u8; 8] = b"TTPCACHE";

/// FNV-1a, 64 bits: the file's checksum (against truncation and damage,
/// not against tampering; the driver validates the data it is given too).
fn checksum(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A cache file's bytes: magic, identity length and identity, data
/// length and checksum, data.
fn encode(identity: &str, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(32 + identity.len() + data.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(identity.len() as u32).to_le_bytes());
    out.extend_from_slice(identity.as_bytes());
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&checksum(data).to_le_bytes());
    out.extend_from_slice(data);
    out
}

/// The data of a cache file written for `identity`, or why it is not
/// usable.
fn decode<'b>(bytes: &'b [u8], identity: &str) -> Result<&'b [u8], String> {
    let corrupt = || "it is damaged or not a twintrace pipeline cache".to_string();
    let rest = bytes.strip_prefix(&MAGIC[..]).ok_or_else(corrupt)?;
    let (len, rest) = rest.split_first_chunk::<4>().ok_or_else(corrupt)?;
    let len = u32::from_le_bytes(*len) as usize;
    if rest.len() < len {
        return Err(corrupt());
    }
    let (id, rest) = rest.split_at(len);
    let (data_len, rest) = rest.split_first_chunk::<8>().ok_or_else(corrupt)?;
    let (sum, data) = rest.split_first_chunk::<8>().ok_or_else(corrupt)?;
    if u64::from_le_bytes(*data_len) != data.len() as u64
        || u64::from_le_bytes(*sum) != checksum(data)
    {
        return Err(corrupt());
    }
    if id != identity.as_bytes() {
        return Err(format!(
            "it was written for another adapter, driver or version ({})",
            String::from_utf8_lossy(id)
        ));
    }
    Ok(data)
}

impl DiskCache {
    /// Opens the pipeline cache of `device` (which must have
    /// `Features::PIPELINE_CACHE`) in `dir`, loading what the file holds
    /// for this adapter; a warning where a file was there and could not be
    /// used.
    pub(crate) fn open(
        device: &wgpu::Device,
        info: &wgpu::AdapterInfo,
        dir: &Path,
    ) -> (Option<DiskCache>, Option<String>) {
        let Some(key) = wgpu::util::pipeline_cache_key(info) else {
            return (None, None);
        };
        let path = dir.join(format!("pipelines-{key}.bin"));
        let identity = format!(
            "{} | {} | {} | {} | twintrace {}",
            info.name,
            info.driver,
            info.driver_info,
            key,
            env!("CARGO_PKG_VERSION")
        );
        let mut warning = None;
        let bytes = match std::fs::read(&path) {
            Ok(b) => Some(b),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => {
                warning = Some(format!(
                    "pipeline cache {}: cannot read it ({e}); kernels are compiled anew",
                    path.display()
                ));
                None
            }
        };
        let data = bytes.as_deref().and_then(|b| match decode(b, &identity) {
            Ok(d) => Some(d),
            Err(why) => {
                warning = Some(format!(
                    "pipeline cache {} ignored: {why}; it will be replaced",
                    path.display()
                ));
                None
            }
        });
        // SAFETY: wgpu asks that the data come from `PipelineCache::get_data`
        // of a compatible adapter. The file's header names the adapter,
        // driver and version it was written for, its checksum matches, and
        // `fallback` makes wgpu start an empty cache where the driver still
        // finds the data unusable.
        let cache = unsafe {
            device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                label: Some("twintrace pipelines"),
                data,
                fallback: true,
            })
        };
        let loaded = data.map_or(0, <[u8]>::len);
        let loaded_checksum = data.map(checksum);
        (
            Some(DiskCache {
                cache,
                path,
                identity,
                loaded,
                loaded_checksum,
            }),
            warning,
        )
    }

    /// Writes the cache's data back to its file (a temporary file in the
    /// same folder, renamed into place: another process reading it sees
    /// the old file or the new one, never a part). Errors are returned
    /// for the caller to report or drop: a cache that cannot be written
    /// costs only the next run's compile time.
    pub(crate) fn save(&self) -> std::io::Result<()> {
        let Some(data) = self.cache.get_data() else {
            return Ok(());
        };
        if data.is_empty()
            || (data.len() == self.loaded && self.loaded_checksum == Some(checksum(&data)))
        {
            return Ok(());
        }
        let dir = self.path.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir)?;
        let mut tmp = tempfile::NamedTempFile::new_in(dir)?;
        std::io::Write::write_all(&mut tmp, &encode(&self.identity, &data))?;
        tmp.persist(&self.path).map_err(|e| e.error)?;
        Ok(())
    }

    pub(crate) fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lru_keeps_the_most_recently_used() {
        let mut l = Lru::new(3);
        for k in 0..3 {
            l.insert(k, k * 10);
        }
        assert_eq!(l.get(&0), Some(0));
        l.insert(3, 30);
        assert_eq!(l.len(), 3);
        assert_eq!(l.get(&1), None, "the least recently used went");
        assert_eq!(
            (l.get(&0), l.get(&2), l.get(&3)),
            (Some(0), Some(20), Some(30))
        );
        l.insert(2, 21);
        assert_eq!((l.len(), l.get(&2)), (3, Some(21)));
    }

    #[test]
    fn a_cache_file_round_trips_and_refuses_damage_and_strangers() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        let bytes = encode("adapter A | driver 1", &data);
        assert_eq!(decode(&bytes, "adapter A | driver 1").unwrap(), &data[..]);
        let foreign = decode(&bytes, "adapter B | driver 1").unwrap_err();
        assert!(foreign.contains("another adapter"), "{foreign}");
        for cut in [0, 4, 8, 12, 30, bytes.len() - 1] {
            assert!(
                decode(&bytes[..cut], "adapter A | driver 1").is_err(),
                "cut at {cut}"
            );
        }
        let mut flipped = bytes.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 1;
        let damaged = decode(&flipped, "adapter A | driver 1").unwrap_err();
        assert!(damaged.contains("damaged"), "{damaged}");
    }
}
