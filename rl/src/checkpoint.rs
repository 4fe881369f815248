//! Checkpoint files: everything needed to act and to resume, written atomically.
//!
//! ## Format (version 1), little-endian
//!
//! ```text
//! offset  size  content
//! 0       8     magic b"CNTRCKPT"
//! 8       4     format version (u32) = 1
//! 12      8     metadata length m (u64)
//! 20      m     metadata: UTF-8 JSON {"algo", "meta": {...}, "blobs": [{"name", "dtype", "len"}, …]}
//! 20+m    …     the blobs' data, in the order listed; dtype f32 / f64 / u64 (8 bytes) / u8
//! end−8   8     FNV-1a 64-bit hash of every preceding byte
//! ```
//!
//! The JSON holds the algorithm name, its config and small counters; numbers that must
//! round-trip bit for bit (weights, optimiser moments, normaliser statistics, RNG words)
//! are blobs. Every algorithm writes a `policy` entry and `policy/…` blobs that
//! [`crate::Policy::load`] reads alone.
//!
//! Files are written to a temporary file unique to the writer (`<name>.<pid>-<n>.tmp`) in
//! the same directory, flushed and `fsync`ed, then renamed over the target, so a crash never
//! leaves a half-written checkpoint.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::buffer::{ReplayBuffer, ReplayRaw};
use crate::nn::Mlp;
use crate::normalizer::RunningMeanStd;
use crate::optim::Adam;
use centaur_gym::BoxSpace;
use centaur_gym::{Rng, RngState};

/// File magic.
pub const MAGIC: &[u8; 8] = b"CNTRCKPT";
/// Current format version.
pub const VERSION: u32 = 1;

/// Why a checkpoint could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// The file system refused.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The file does not start with the checkpoint magic.
    #[error("{path}: not a Centaur checkpoint (bad magic)")]
    NotACheckpoint {
        /// File.
        path: PathBuf,
    },
    /// Written by another format version.
    #[error("{path}: checkpoint format version {found}, this build reads version {supported}")]
    UnsupportedVersion {
        /// File.
        path: PathBuf,
        /// Version in the file.
        found: u32,
        /// Version this build reads.
        supported: u32,
    },
    /// The file is shorter than its header says.
    #[error("{path}: truncated checkpoint ({found} bytes, at least {expected} expected)")]
    Truncated {
        /// File.
        path: PathBuf,
        /// Bytes expected.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// The content does not match its checksum.
    #[error("{path}: checksum mismatch (file corrupted)")]
    Checksum {
        /// File.
        path: PathBuf,
    },
    /// The metadata is not what this build expects.
    #[error("{path}: bad checkpoint metadata: {reason}")]
    Metadata {
        /// File.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A blob is missing or has the wrong type or size.
    #[error("{path}: checkpoint entry `{name}`: {reason}")]
    Entry {
        /// File.
        path: PathBuf,
        /// Entry name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// The checkpoint was written by another algorithm.
    #[error("{path}: checkpoint of a `{found}` learner, expected `{expected}`")]
    WrongAlgorithm {
        /// File.
        path: PathBuf,
        /// Algorithm expected.
        expected: String,
        /// Algorithm in the file.
        found: String,
    },
}

/// A typed array stored in a checkpoint.
#[derive(Clone, Debug, PartialEq)]
pub enum Blob {
    /// `f32` values.
    F32(Vec<f32>),
    /// `f64` values.
    F64(Vec<f64>),
    /// `u64` values.
    U64(Vec<u64>),
    /// Bytes (e.g. flags).
    U8(Vec<u8>),
}

impl Blob {
    fn dtype(&self) -> &'static str {
        match self {
            Blob::F32(_) => "f32",
            Blob::F64(_) => "f64",
            Blob::U64(_) => "u64",
            Blob::U8(_) => "u8",
        }
    }

    fn len(&self) -> usize {
        match self {
            Blob::F32(v) => v.len(),
            Blob::F64(v) => v.len(),
            Blob::U64(v) => v.len(),
            Blob::U8(v) => v.len(),
        }
    }
}

/// FNV-1a, 64 bit (Fowler, Noll, Vo).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The contents of a checkpoint file, in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Algorithm name (`"ppo"`, `"sac"`, …).
    pub algo: String,
    /// JSON metadata (config, counters, policy description).
    pub meta: serde_json::Map<String, serde_json::Value>,
    blobs: Vec<(String, Blob)>,
    /// Where it was read from (for error messages).
    path: PathBuf,
}

impl Checkpoint {
    /// An empty checkpoint for `algo`.
    pub fn new(algo: &str) -> Checkpoint {
        Checkpoint {
            algo: algo.to_string(),
            meta: Default::default(),
            blobs: Vec::new(),
            path: PathBuf::new(),
        }
    }

    /// The file this checkpoint was read from (empty if built in memory).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Stores a serialisable metadata value.
    pub fn set_meta(&mut self, key: &str, value: impl Serialize) {
        let v = serde_json::to_value(value).expect("checkpoint metadata serialises to JSON");
        self.meta.insert(key.to_string(), v);
    }

    /// Whether the metadata holds `key` (to tell a missing value from a corrupt one).
    pub fn has_meta(&self, key: &str) -> bool {
        self.meta.contains_key(key)
    }

    /// Reads a metadata value.
    pub fn get_meta<T: DeserializeOwned>(&self, key: &str) -> Result<T, CheckpointError> {
        let v = self.meta.get(key).ok_or_else(|| self.meta_err(format!("missing `{key}`")))?;
        T::deserialize(v).map_err(|e| self.meta_err(format!("`{key}`: {e}")))
    }

    fn meta_err(&self, reason: String) -> CheckpointError {
        CheckpointError::Metadata { path: self.path.clone(), reason }
    }

    fn entry_err(&self, name: &str, reason: String) -> CheckpointError {
        CheckpointError::Entry { path: self.path.clone(), name: name.to_string(), reason }
    }

    /// Fails unless the checkpoint belongs to `algo`.
    pub fn expect_algo(&self, algo: &str) -> Result<(), CheckpointError> {
        if self.algo == algo {
            Ok(())
        } else {
            Err(CheckpointError::WrongAlgorithm {
                path: self.path.clone(),
                expected: algo.to_string(),
                found: self.algo.clone(),
            })
        }
    }

    /// Adds (or replaces) a blob.
    pub fn put(&mut self, name: &str, blob: Blob) {
        if let Some(slot) = self.blobs.iter_mut().find(|(n, _)| n == name) {
            slot.1 = blob;
        } else {
            self.blobs.push((name.to_string(), blob));
        }
    }

    /// Adds an `f32` blob.
    pub fn put_f32(&mut self, name: &str, data: &[f32]) {
        self.put(name, Blob::F32(data.to_vec()));
    }

    /// Adds an `f64` blob.
    pub fn put_f64(&mut self, name: &str, data: &[f64]) {
        self.put(name, Blob::F64(data.to_vec()));
    }

    /// Adds a `u64` blob.
    pub fn put_u64(&mut self, name: &str, data: &[u64]) {
        self.put(name, Blob::U64(data.to_vec()));
    }

    /// Adds a flag blob.
    pub fn put_bools(&mut self, name: &str, data: &[bool]) {
        self.put(name, Blob::U8(data.iter().map(|b| *b as u8).collect()));
    }

    fn blob(&self, name: &str) -> Result<&Blob, CheckpointError> {
        self.blobs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| b)
            .ok_or_else(|| self.entry_err(name, "missing".into()))
    }

    /// An `f32` blob, checking its length if `len` is given.
    pub fn f32(&self, name: &str, len: Option<usize>) -> Result<&[f32], CheckpointError> {
        match self.blob(name)? {
            Blob::F32(v) => self.check_len(name, v, len),
            b => Err(self.entry_err(name, format!("stored as {}, expected f32", b.dtype()))),
        }
    }

    /// An `f64` blob.
    pub fn f64(&self, name: &str, len: Option<usize>) -> Result<&[f64], CheckpointError> {
        match self.blob(name)? {
            Blob::F64(v) => self.check_len(name, v, len),
            b => Err(self.entry_err(name, format!("stored as {}, expected f64", b.dtype()))),
        }
    }

    /// A `u64` blob.
    pub fn u64(&self, name: &str, len: Option<usize>) -> Result<&[u64], CheckpointError> {
        match self.blob(name)? {
            Blob::U64(v) => self.check_len(name, v, len),
            b => Err(self.entry_err(name, format!("stored as {}, expected u64", b.dtype()))),
        }
    }

    /// A flag blob.
    pub fn bools(&self, name: &str, len: Option<usize>) -> Result<Vec<bool>, CheckpointError> {
        match self.blob(name)? {
            Blob::U8(v) => Ok(self.check_len(name, v, len)?.iter().map(|b| *b != 0).collect()),
            b => Err(self.entry_err(name, format!("stored as {}, expected u8", b.dtype()))),
        }
    }

    /// Copies an `f32` blob into `dst` (lengths must match).
    pub fn read_f32_into(&self, name: &str, dst: &mut [f32]) -> Result<(), CheckpointError> {
        dst.copy_from_slice(self.f32(name, Some(dst.len()))?);
        Ok(())
    }

    fn check_len<'a, T>(
        &self,
        name: &str,
        v: &'a [T],
        len: Option<usize>,
    ) -> Result<&'a [T], CheckpointError> {
        match len {
            Some(l) if l != v.len() => Err(self.entry_err(name, format!("{} values, expected {l}", v.len()))),
            _ => Ok(v),
        }
    }

    /// Stores an Adam optimiser's moments and step count under `name/…`.
    pub fn put_adam(&mut self, name: &str, adam: &Adam) {
        let (m, v, t) = adam.moments();
        self.put_f32(&format!("{name}/m"), m);
        self.put_f32(&format!("{name}/v"), v);
        self.put_u64(&format!("{name}/t"), &[t]);
    }

    /// Restores an Adam optimiser written by [`Checkpoint::put_adam`].
    pub fn read_adam(&self, name: &str, adam: &mut Adam) -> Result<(), CheckpointError> {
        let n = adam.len();
        let m = self.f32(&format!("{name}/m"), Some(n))?;
        let v = self.f32(&format!("{name}/v"), Some(n))?;
        let t = self.u64(&format!("{name}/t"), Some(1))?[0];
        adam.restore(m, v, t);
        Ok(())
    }

    /// Stores a generator's full state.
    pub fn put_rng(&mut self, name: &str, rng: &Rng) {
        let s = rng.state();
        self.put_u64(name, &[s.words[0], s.words[1], s.words[2], s.words[3], s.spare.to_bits()]);
    }

    /// Restores a generator written by [`Checkpoint::put_rng`].
    pub fn read_rng(&self, name: &str) -> Result<Rng, CheckpointError> {
        let w = self.u64(name, Some(5))?;
        Ok(Rng::from_state(RngState { words: [w[0], w[1], w[2], w[3]], spare: f64::from_bits(w[4]) }))
    }

    /// Stores running statistics under `name/…`.
    pub fn put_rms(&mut self, name: &str, rms: &RunningMeanStd) {
        self.put_f64(&format!("{name}/mean"), &rms.mean);
        self.put_f64(&format!("{name}/var"), &rms.var);
        self.put_f64(&format!("{name}/count"), &[rms.count]);
    }

    /// Restores running statistics written by [`Checkpoint::put_rms`].
    pub fn read_rms(&self, name: &str, rms: &mut RunningMeanStd) -> Result<(), CheckpointError> {
        let d = rms.dim();
        let mean = self.f64(&format!("{name}/mean"), Some(d))?;
        let var = self.f64(&format!("{name}/var"), Some(d))?;
        let count = self.f64(&format!("{name}/count"), Some(1))?[0];
        rms.restore(mean, var, count);
        Ok(())
    }

    /// Stores a box space's bounds.
    pub fn put_space(&mut self, name: &str, space: &BoxSpace) {
        self.put_f32(&format!("{name}/low"), &space.low);
        self.put_f32(&format!("{name}/high"), &space.high);
    }

    /// Restores a box space written by [`Checkpoint::put_space`].
    pub fn read_space(&self, name: &str) -> Result<BoxSpace, CheckpointError> {
        let low = self.f32(&format!("{name}/low"), None)?.to_vec();
        let high = self.f32(&format!("{name}/high"), Some(low.len()))?.to_vec();
        Ok(BoxSpace::new(low, high))
    }

    /// Stores a replay buffer's filled part under `name/…`.
    pub fn put_replay(&mut self, name: &str, rb: &ReplayBuffer) {
        let raw = rb.raw();
        self.put_f32(&format!("{name}/obs"), raw.obs);
        self.put_f32(&format!("{name}/actions"), raw.actions);
        self.put_f32(&format!("{name}/rewards"), raw.rewards);
        self.put_f32(&format!("{name}/next_obs"), raw.next_obs);
        self.put_bools(&format!("{name}/terminated"), raw.terminated);
        self.put_bools(&format!("{name}/truncated"), raw.truncated);
        self.put_u64(&format!("{name}/pos"), &[raw.pos as u64]);
    }

    /// Refills a replay buffer written by [`Checkpoint::put_replay`].
    pub fn read_replay(&self, name: &str, rb: &mut ReplayBuffer) -> Result<(), CheckpointError> {
        let terminated = self.bools(&format!("{name}/terminated"), None)?;
        let truncated = self.bools(&format!("{name}/truncated"), Some(terminated.len()))?;
        let raw = ReplayRaw {
            obs: self.f32(&format!("{name}/obs"), None)?,
            actions: self.f32(&format!("{name}/actions"), None)?,
            rewards: self.f32(&format!("{name}/rewards"), Some(terminated.len()))?,
            next_obs: self.f32(&format!("{name}/next_obs"), None)?,
            terminated: &terminated,
            truncated: &truncated,
            pos: self.u64(&format!("{name}/pos"), Some(1))?[0] as usize,
        };
        if rb.restore(&raw) {
            Ok(())
        } else {
            Err(self.entry_err(name, "replay buffer sizes inconsistent".into()))
        }
    }

    /// Copies a network's parameters from blob `name`.
    pub fn read_mlp(&self, name: &str, net: &mut Mlp) -> Result<(), CheckpointError> {
        self.read_f32_into(name, &mut net.params)
    }

    /// Serialises to the file format.
    pub fn to_bytes(&self) -> Vec<u8> {
        let blobs: Vec<serde_json::Value> = self
            .blobs
            .iter()
            .map(|(n, b)| serde_json::json!({"name": n, "dtype": b.dtype(), "len": b.len()}))
            .collect();
        let header = serde_json::json!({"algo": self.algo, "meta": self.meta, "blobs": blobs});
        let json = serde_json::to_vec(&header).expect("JSON metadata serialises");
        let mut out =
            Vec::with_capacity(28 + json.len() + self.blobs.iter().map(|(_, b)| b.len() * 8).sum::<usize>());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(json.len() as u64).to_le_bytes());
        out.extend_from_slice(&json);
        for (_, b) in &self.blobs {
            match b {
                Blob::F32(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
                Blob::F64(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
                Blob::U64(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
                Blob::U8(v) => out.extend_from_slice(v),
            }
        }
        let h = fnv1a64(&out);
        out.extend_from_slice(&h.to_le_bytes());
        out
    }

    /// Parses the file format; `path` is only used in error messages.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Checkpoint, CheckpointError> {
        let p = || path.to_path_buf();
        let truncated =
            |expected: u64| CheckpointError::Truncated { path: p(), expected, found: bytes.len() as u64 };
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            return Err(CheckpointError::NotACheckpoint { path: p() });
        }
        if bytes.len() < 20 {
            return Err(truncated(28));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != VERSION {
            return Err(CheckpointError::UnsupportedVersion {
                path: p(),
                found: version,
                supported: VERSION,
            });
        }
        let m = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
        let json_end = 20u64.checked_add(m).ok_or_else(|| truncated(u64::MAX))?;
        if (bytes.len() as u64) < json_end.saturating_add(8) {
            return Err(truncated(json_end.saturating_add(8)));
        }
        let body_len = bytes.len() - 8;
        let stored = u64::from_le_bytes(bytes[body_len..].try_into().expect("8 bytes"));
        let meta_err = |reason: String| CheckpointError::Metadata { path: p(), reason };
        let header: serde_json::Value =
            serde_json::from_slice(&bytes[20..json_end as usize]).map_err(|e| {
                if fnv1a64(&bytes[..body_len]) != stored {
                    CheckpointError::Checksum { path: p() }
                } else {
                    meta_err(format!("invalid JSON: {e}"))
                }
            })?;
        // Sizes first (a truncated file is reported as such), then the checksum.
        let list = header["blobs"].as_array().ok_or_else(|| meta_err("no `blobs` list".into()))?;
        let mut specs = Vec::with_capacity(list.len());
        let mut total: u64 = 0;
        for b in list {
            let name = b["name"].as_str().ok_or_else(|| meta_err("blob without a name".into()))?;
            let dtype =
                b["dtype"].as_str().ok_or_else(|| meta_err(format!("blob `{name}` without dtype")))?;
            let len = b["len"].as_u64().ok_or_else(|| meta_err(format!("blob `{name}` without len")))?;
            let width = match dtype {
                "f32" => 4,
                "f64" | "u64" => 8,
                "u8" => 1,
                d => return Err(meta_err(format!("blob `{name}` has unknown dtype `{d}`"))),
            };
            total = len
                .checked_mul(width)
                .and_then(|s| total.checked_add(s))
                .ok_or_else(|| meta_err(format!("blob `{name}` too large")))?;
            specs.push((name.to_string(), dtype, len as usize));
        }
        let expected = json_end.saturating_add(total).saturating_add(8);
        if (bytes.len() as u64) < expected {
            return Err(truncated(expected));
        }
        if fnv1a64(&bytes[..body_len]) != stored {
            return Err(CheckpointError::Checksum { path: p() });
        }
        if (bytes.len() as u64) != expected {
            return Err(meta_err(format!("{} bytes after the blobs", bytes.len() as u64 - expected)));
        }
        let algo = header["algo"].as_str().ok_or_else(|| meta_err("no `algo`".into()))?.to_string();
        let meta = header["meta"].as_object().ok_or_else(|| meta_err("no `meta` object".into()))?.clone();
        let mut at = json_end as usize;
        let mut blobs = Vec::with_capacity(specs.len());
        for (name, dtype, len) in specs {
            let blob = match dtype {
                "f32" => Blob::F32(
                    bytes[at..at + 4 * len]
                        .chunks_exact(4)
                        .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
                        .collect(),
                ),
                "f64" => Blob::F64(
                    bytes[at..at + 8 * len]
                        .chunks_exact(8)
                        .map(|c| f64::from_le_bytes(c.try_into().expect("8")))
                        .collect(),
                ),
                "u64" => Blob::U64(
                    bytes[at..at + 8 * len]
                        .chunks_exact(8)
                        .map(|c| u64::from_le_bytes(c.try_into().expect("8")))
                        .collect(),
                ),
                _ => Blob::U8(bytes[at..at + len].to_vec()),
            };
            at += match dtype {
                "f32" => 4 * len,
                "u8" => len,
                _ => 8 * len,
            };
            blobs.push((name, blob));
        }
        Ok(Checkpoint { algo, meta, blobs, path: p() })
    }

    /// Writes atomically: a temporary file unique to this process and call
    /// (`<path>.<pid>-<n>.tmp`) in the same directory, `fsync`, rename over `path`. Two
    /// writers of one path never share a temporary file; the last rename wins whole. On a
    /// failure the temporary file is removed and the error names it.
    pub fn write(&self, path: &Path) -> Result<(), CheckpointError> {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(format!(".{}-{n}.tmp", std::process::id()));
        let tmp = PathBuf::from(tmp);
        let written = (|| {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(&self.to_bytes())?;
            f.sync_all()
        })();
        if let Err(source) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(CheckpointError::Io { path: tmp, source });
        }
        let io = |source| CheckpointError::Io { path: path.to_path_buf(), source };
        if let Err(source) = std::fs::rename(&tmp, path) {
            let _ = std::fs::remove_file(&tmp);
            return Err(io(source));
        }
        // Make the rename durable too (best effort: directories cannot be opened everywhere).
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
            && let Ok(d) = std::fs::File::open(dir)
        {
            let _ = d.sync_all();
        }
        Ok(())
    }

    /// Reads and verifies a checkpoint file.
    pub fn read(path: &Path) -> Result<Checkpoint, CheckpointError> {
        let bytes =
            std::fs::read(path).map_err(|source| CheckpointError::Io { path: path.to_path_buf(), source })?;
        Checkpoint::from_bytes(&bytes, path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Checkpoint {
        let mut c = Checkpoint::new("ppo");
        c.set_meta("steps", 1234u64);
        c.set_meta("lr", 3e-4f64);
        c.put_f32("w", &[1.0, -2.5, f32::MIN_POSITIVE]);
        c.put_f64("mean", &[0.1, 1e300]);
        c.put_u64("rng", &[u64::MAX, 7]);
        c.put_bools("flags", &[true, false, true]);
        c
    }

    #[test]
    fn round_trip() {
        let c = sample();
        let d = Checkpoint::from_bytes(&c.to_bytes(), Path::new("x")).unwrap();
        assert_eq!(d.algo, "ppo");
        assert_eq!(d.get_meta::<u64>("steps").unwrap(), 1234);
        assert_eq!(d.get_meta::<f64>("lr").unwrap().to_bits(), 3e-4f64.to_bits());
        assert_eq!(d.f32("w", Some(3)).unwrap(), &[1.0, -2.5, f32::MIN_POSITIVE]);
        assert_eq!(d.f64("mean", None).unwrap(), &[0.1, 1e300]);
        assert_eq!(d.u64("rng", None).unwrap(), &[u64::MAX, 7]);
        assert_eq!(d.bools("flags", None).unwrap(), vec![true, false, true]);
        assert!(matches!(d.f32("w", Some(4)), Err(CheckpointError::Entry { .. })));
        assert!(matches!(d.f32("mean", None), Err(CheckpointError::Entry { .. })));
        assert!(matches!(d.f32("nope", None), Err(CheckpointError::Entry { .. })));
        assert!(matches!(d.expect_algo("sac"), Err(CheckpointError::WrongAlgorithm { .. })));
    }

    #[test]
    fn corrupt_truncated_and_foreign_files_are_typed_errors() {
        let bytes = sample().to_bytes();
        let p = Path::new("c");
        // Every truncation is refused (never a panic).
        for cut in 0..bytes.len() {
            let e = Checkpoint::from_bytes(&bytes[..cut], p).unwrap_err();
            assert!(
                matches!(
                    e,
                    CheckpointError::Truncated { .. }
                        | CheckpointError::NotACheckpoint { .. }
                        | CheckpointError::Checksum { .. }
                        | CheckpointError::Metadata { .. }
                ),
                "cut {cut}: {e}"
            );
        }
        // Every single flipped bit is caught.
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            assert!(Checkpoint::from_bytes(&b, p).is_err(), "flip at {i} accepted");
        }
        let mut b = bytes.clone();
        b[8] = 2;
        assert!(matches!(
            Checkpoint::from_bytes(&b, p),
            Err(CheckpointError::UnsupportedVersion { found: 2, supported: 1, .. })
        ));
        assert!(matches!(
            Checkpoint::from_bytes(b"PK\x03\x04 zip", p),
            Err(CheckpointError::NotACheckpoint { .. })
        ));
    }

    #[test]
    fn atomic_write_and_read() {
        let dir = std::env::temp_dir().join(format!("centaur-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("model.ckpt");
        sample().write(&path).unwrap();
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left, [std::ffi::OsString::from("model.ckpt")], "temporary files left behind");
        let d = Checkpoint::read(&path).unwrap();
        assert_eq!(d.f32("w", None).unwrap()[1], -2.5);
        assert!(matches!(Checkpoint::read(&dir.join("missing")), Err(CheckpointError::Io { .. })));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
