//! The content-addressed cache on disk.
//!
//! ```text
//! <cache>/blobs/<aa>/<hash>          file contents, named by their blake3 hash (immutable)
//! <cache>/trees/<aa>/<digest>.json   artifact manifests: a folder (paths → blobs) or a
//!                                    collection (item names → artifact digests); the
//!                                    digest is the blake3 hash of the manifest bytes
//! <cache>/actions/<aa>/<key>.json    one record per node run (or item run), keyed by
//!                                    the run's cache key: outputs, time, notes and
//!                                    measurements; carries its own checksum
//! <cache>/heads/<graph>.json        the last keys each node of a graph ran with (for `explain`)
//! <cache>/locks/<aa>/<key>.lock      held while a key is being computed (cross-process)
//! <cache>/tmp/<pid>-<n>/             staging; renamed into place, never read across processes
//! <cache>/slurm/                     job files of `--executor slurm` runs (see the Slurm executor)
//! ```
//!
//! Every write is temp-file + rename, so a crash leaves either nothing or a whole
//! entry. Every read is verified against its name; a corrupt entry is reported,
//! deleted and recomputed, never served.

use anyhow::{Context as _, Result, anyhow, bail};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashSet};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

pub type Digest = String;

/// Marks a folder as an objectsplat cache (the CACHEDIR.TAG convention, which also
/// tells backup tools to skip it).
const CACHE_TAG: &str = "CACHEDIR.TAG";
const CACHE_TAG_TEXT: &str = "Signature: 8a477f597d28d172789f06886806bc55\n# objectsplat cache (content-addressed; safe to delete)\n";

/// A cache deletes what it finds stale inside itself, so it must never adopt a
/// folder that holds something else: only a new or empty folder, one it tagged, or
/// one laid out as a cache by an older objectsplat (`blobs/` and `actions/`).
fn refuse_foreign_folder(root: &Path) -> Result<()> {
    let Ok(mut entries) = fs::read_dir(root) else {
        return Ok(());
    };
    if entries.next().is_none()
        || root.join(CACHE_TAG).is_file()
        || (root.join("blobs").is_dir() && root.join("actions").is_dir())
    {
        return Ok(());
    }
    bail!(
        "{}: not an objectsplat cache (the folder holds other files); give --cache a new or empty folder",
        root.display()
    )
}

/// A stored artifact: one folder, or a collection of named items.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Manifest {
    Folder {
        ty: String,
        files: Vec<FileEntry>,
    },
    Collection {
        ty: String,
        items: Vec<(String, Digest)>,
    },
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileEntry {
    pub path: String,
    pub blob: String,
    pub size: u64,
}

/// What a cached run produced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionRecord {
    pub key: String,
    pub node: String,
    pub kind: String,
    pub version: String,
    pub item: Option<String>,
    pub params: String,
    pub inputs: BTreeMap<String, Digest>,
    pub outputs: BTreeMap<String, Digest>,
    /// `ran` or `skipped`.
    pub status: String,
    pub reason: Option<String>,
    pub seconds: f64,
    pub notes: Vec<(String, String)>,
    /// What the run measured about itself ([`crate::Context::measurement`]): reported
    /// with every hit of this record, never part of its outputs.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub measurements: BTreeMap<String, serde_json::Value>,
    /// Where the run happened (absent in records written before this was kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ran_on: Option<RanOn>,
}

/// Where an action was computed: for the run report and for finding who computed what
/// when several coordinators or cluster jobs share one cache.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RanOn {
    /// `local` (in the coordinating process) or `slurm` (a cluster job).
    pub executor: String,
    /// The machine's host name (the Slurm node name for a job).
    pub host: String,
    /// The Slurm job (`<array job>_<task>`), for `slurm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub job_id: Option<String>,
    /// The computing process.
    pub pid: u32,
}

impl RanOn {
    /// This process, computing in the coordinator.
    pub fn local() -> RanOn {
        RanOn {
            executor: "local".into(),
            host: crate::host::host_name(),
            job_id: None,
            pid: std::process::id(),
        }
    }
}

#[derive(Serialize, Deserialize)]
struct Sealed<T> {
    checksum: String,
    body: T,
}

pub struct Store {
    root: PathBuf,
    tmp: PathBuf,
    counter: AtomicU64,
    /// Blobs verified by this process (each is read once at most).
    verified: Mutex<HashSet<String>>,
    /// Fan-out folders known to exist (saves a failing mkdir per write).
    made_dirs: Mutex<HashSet<PathBuf>>,
    /// Kept open: its lock tells other processes this staging area is alive.
    _tmp_lock: fs::File,
}

#[derive(Debug, thiserror::Error)]
#[error("cache entry {what} is corrupt: {detail}")]
pub struct Corrupt {
    pub what: String,
    pub detail: String,
}

fn hex2(h: &str) -> &str {
    &h[..2.min(h.len())]
}

fn hash_bytes(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

impl Store {
    pub fn open(root: &Path) -> Result<Store> {
        refuse_foreign_folder(root)?;
        fs::create_dir_all(root)
            .with_context(|| format!("{}: cannot create cache folder", root.display()))?;
        // The tag is the first thing in a new cache, so a concurrent `open` never sees
        // a non-empty folder without it.
        let tag = root.join(CACHE_TAG);
        if !tag.exists() {
            fs::write(&tag, CACHE_TAG_TEXT)
                .with_context(|| format!("{}: cannot write", tag.display()))?;
        }
        for d in ["blobs", "trees", "actions", "heads", "locks", "tmp"] {
            fs::create_dir_all(root.join(d)).with_context(|| {
                format!("{}: cannot create cache folder", root.join(d).display())
            })?;
        }
        let root = root
            .canonicalize()
            .with_context(|| format!("{}: cannot resolve", root.display()))?;
        Self::clean_stale_staging(&root.join("tmp"));
        let tmp = root
            .join("tmp")
            .join(format!("{}-{}", std::process::id(), unique_suffix()));
        fs::create_dir_all(&tmp)?;
        let lock = fs::File::create(tmp.with_extension("lock"))?;
        lock.lock()?;
        Ok(Store {
            root,
            tmp,
            counter: AtomicU64::new(0),
            verified: Mutex::new(HashSet::new()),
            made_dirs: Mutex::new(HashSet::new()),
            _tmp_lock: lock,
        })
    }

    /// Removes staging folders whose process is gone (their lock is free). Only names
    /// this store creates (`<pid>-<nanos>` and its `.lock`) are touched, so a cache
    /// pointed at a folder that holds other things never loses them.
    fn clean_stale_staging(tmp_root: &Path) {
        let Ok(entries) = fs::read_dir(tmp_root) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            let Some(stem) = e
                .file_name()
                .to_str()
                .and_then(|n| n.strip_suffix(".lock"))
                .map(str::to_string)
            else {
                continue;
            };
            if !is_staging_name(&stem) || !e.file_type().is_ok_and(|t| t.is_file()) {
                continue;
            }
            let dir = tmp_root.join(&stem);
            let is_real_dir = fs::symlink_metadata(&dir).is_ok_and(|m| m.is_dir());
            if let Ok(f) = fs::File::open(&p)
                && f.try_lock().is_ok()
            {
                if is_real_dir {
                    let _ = fs::remove_dir_all(&dir);
                }
                let _ = fs::remove_file(&p);
            }
        }
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    /// A fresh empty staging folder (inside the cache, same filesystem as the CAS).
    pub fn staging(&self, label: &str) -> Result<PathBuf> {
        let n = self.counter.fetch_add(1, Ordering::Relaxed);
        let safe: String = label
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .take(40)
            .collect();
        let p = self.tmp.join(format!("{n}-{safe}"));
        fs::create_dir_all(&p)?;
        Ok(p)
    }

    fn ensure_parent(&self, path: &Path) -> Result<()> {
        let Some(parent) = path.parent() else {
            return Ok(());
        };
        if self
            .made_dirs
            .lock()
            .map(|d| d.contains(parent))
            .unwrap_or(false)
        {
            return Ok(());
        }
        fs::create_dir_all(parent)
            .with_context(|| format!("{}: cannot create", parent.display()))?;
        if let Ok(mut d) = self.made_dirs.lock() {
            d.insert(parent.to_path_buf());
        }
        Ok(())
    }

    fn blob_path(&self, hash: &str) -> PathBuf {
        self.root.join("blobs").join(hex2(hash)).join(hash)
    }

    fn tree_path(&self, digest: &str) -> PathBuf {
        self.root
            .join("trees")
            .join(hex2(digest))
            .join(format!("{digest}.json"))
    }

    fn action_path(&self, key: &str) -> PathBuf {
        self.root
            .join("actions")
            .join(hex2(key))
            .join(format!("{key}.json"))
    }

    /// Writes bytes to `dest` atomically (temp file in the staging area, then rename).
    fn write_atomic(&self, dest: &Path, bytes: &[u8]) -> Result<()> {
        let n = self.counter.fetch_add(1, Ordering::Relaxed);
        let tmp = self.tmp.join(format!("w{n}"));
        {
            let mut f = fs::File::create(&tmp)?;
            // No fsync: rename makes the entry appear whole or not at all, which is what a
            // killed process needs; after a power loss a torn entry fails its checksum and
            // is recomputed.
            f.write_all(bytes)?;
        }
        self.ensure_parent(dest)?;
        fs::rename(&tmp, dest).with_context(|| format!("{}: cannot write", dest.display()))
    }

    /// Moves the files of a finished output folder into the CAS and records a folder manifest.
    pub fn ingest_folder(&self, ty: &str, dir: &Path) -> Result<Digest> {
        let mut files = Vec::new();
        output_files(dir, dir, &mut files)?;
        files.sort();
        let mut entries = Vec::with_capacity(files.len());
        for rel in files {
            let path = dir.join(&rel);
            let bytes = fs::read(&path)
                .with_context(|| format!("{}: cannot read output", path.display()))?;
            let hash = hash_bytes(&bytes);
            let dest = self.blob_path(&hash);
            // A blob that is already there but fails verification is replaced, so one
            // rerun repairs every corrupt blob it produces.
            if !self.blob_is_sound(&hash) {
                self.ensure_parent(&dest)?;
                // Same filesystem: an atomic move. A concurrent writer of the same hash
                // writes the same bytes, so whichever rename lands last is fine.
                fs::rename(&path, &dest).or_else(|_| self.write_atomic(&dest, &bytes))?;
                set_writable(&dest, false)?;
                self.mark_verified(&hash);
            }
            entries.push(FileEntry {
                path: rel,
                blob: hash,
                size: bytes.len() as u64,
            });
        }
        self.put_manifest(&Manifest::Folder {
            ty: ty.to_string(),
            files: entries,
        })
    }

    /// True when the blob exists as a plain file with the right contents.
    fn blob_is_sound(&self, hash: &str) -> bool {
        if self.is_verified(hash) {
            return true;
        }
        let path = self.blob_path(hash);
        let plain = fs::symlink_metadata(&path).is_ok_and(|m| m.is_file());
        if plain && fs::read(&path).is_ok_and(|b| hash_bytes(&b) == hash) {
            self.mark_verified(hash);
            return true;
        }
        false
    }

    fn is_verified(&self, hash: &str) -> bool {
        self.verified
            .lock()
            .map(|v| v.contains(hash))
            .unwrap_or(false)
    }

    fn mark_verified(&self, hash: &str) {
        if let Ok(mut v) = self.verified.lock() {
            v.insert(hash.to_string());
        }
    }

    pub fn put_manifest(&self, m: &Manifest) -> Result<Digest> {
        let bytes = serde_json::to_vec(m)?;
        let digest = hash_bytes(&bytes);
        let path = self.tree_path(&digest);
        if !path.exists() {
            self.write_atomic(&path, &bytes)?;
        }
        Ok(digest)
    }

    /// Reads and verifies a manifest; `Ok(None)` if absent.
    pub fn manifest(&self, digest: &str) -> Result<Option<Manifest>, Corrupt> {
        let path = self.tree_path(digest);
        let Ok(bytes) = fs::read(&path) else {
            return Ok(None);
        };
        if hash_bytes(&bytes) != digest {
            let _ = fs::remove_file(&path);
            return Err(Corrupt {
                what: format!("manifest {}", short(digest)),
                detail: "checksum mismatch".into(),
            });
        }
        serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| Corrupt {
                what: format!("manifest {}", short(digest)),
                detail: e.to_string(),
            })
    }

    /// True if the artifact and everything it refers to is present (not verified).
    pub fn has_artifact(&self, digest: &str) -> bool {
        match self.manifest(digest) {
            Ok(Some(Manifest::Folder { files, .. })) => {
                files.iter().all(|f| self.blob_path(&f.blob).exists())
            }
            Ok(Some(Manifest::Collection { items, .. })) => {
                items.iter().all(|(_, d)| self.has_artifact(d))
            }
            _ => false,
        }
    }

    fn verify_blob(&self, hash: &str) -> Result<(), Corrupt> {
        if self.is_verified(hash) {
            return Ok(());
        }
        let path = self.blob_path(hash);
        let bad = |detail: String| Corrupt {
            what: format!("blob {}", short(hash)),
            detail,
        };
        if fs::symlink_metadata(&path).is_ok_and(|m| !m.is_file()) {
            let _ = fs::remove_file(&path);
            return Err(bad("not a plain file".into()));
        }
        let bytes = fs::read(&path).map_err(|e| bad(e.to_string()))?;
        if hash_bytes(&bytes) != hash {
            let _ = fs::remove_file(&path);
            return Err(bad("checksum mismatch (file changed on disk)".into()));
        }
        self.mark_verified(hash);
        Ok(())
    }

    /// Verifies every blob an artifact refers to, deleting each corrupt one, and
    /// reports them all at once: one pass finds all the damage an artifact has, so
    /// the next pass can recompute all of it.
    fn verify_artifact(&self, digest: &str) -> Result<Manifest, Corrupt> {
        let m = self.manifest(digest)?.ok_or_else(|| Corrupt {
            what: format!("artifact {}", short(digest)),
            detail: "missing".into(),
        })?;
        let mut bad = Vec::new();
        match &m {
            Manifest::Folder { files, .. } => {
                for f in files {
                    if let Err(c) = check_manifest_path(&f.path, digest) {
                        // A manifest naming a path outside its folder is never laid out.
                        self.forget_artifact(digest);
                        return Err(c);
                    }
                    if let Err(c) = self.verify_blob(&f.blob) {
                        bad.push(c.to_string());
                    }
                }
            }
            Manifest::Collection { items, .. } => {
                for (name, d) in items {
                    if crate::paths::check_component(name).is_err() {
                        self.forget_artifact(digest);
                        return Err(Corrupt {
                            what: format!("artifact {}", short(digest)),
                            detail: format!("item name {name:?} is not a plain folder name"),
                        });
                    }
                    if let Err(c) = self.verify_artifact(d) {
                        bad.push(c.to_string());
                    }
                }
            }
        }
        match bad.len() {
            0 => Ok(m),
            1 => Err(Corrupt {
                what: format!("artifact {}", short(digest)),
                detail: bad.remove(0),
            }),
            n => Err(Corrupt {
                what: format!("artifact {}", short(digest)),
                detail: format!("{n} entries are damaged (first: {})", bad[0]),
            }),
        }
    }

    /// Lays out an artifact as a folder at `dest` (hard links to verified blobs;
    /// copies when `copy` is set, for folders users may edit). Collections become one
    /// sub-folder per item. Returns the items for a collection. Every blob is
    /// verified before anything is written; a corrupt artifact is reported whole.
    pub fn materialize(
        &self,
        digest: &str,
        dest: &Path,
        copy: bool,
    ) -> Result<Option<Vec<(String, PathBuf)>>> {
        let m = self.verify_artifact(digest)?;
        self.lay_out(m, dest, copy)
    }

    fn lay_out(
        &self,
        m: Manifest,
        dest: &Path,
        copy: bool,
    ) -> Result<Option<Vec<(String, PathBuf)>>> {
        fs::create_dir_all(dest).with_context(|| format!("{}: cannot create", dest.display()))?;
        match m {
            Manifest::Folder { files, .. } => {
                for f in files {
                    let target = dest.join(&f.path);
                    if let Some(parent) = target.parent() {
                        fs::create_dir_all(parent)?;
                    }
                    let _ = fs::remove_file(&target);
                    let src = self.blob_path(&f.blob);
                    if copy || fs::hard_link(&src, &target).is_err() {
                        copy_writable(&src, &target)?;
                    }
                }
                Ok(None)
            }
            Manifest::Collection { items, .. } => {
                let mut out = Vec::new();
                for (name, d) in items {
                    let sub = dest.join(&name);
                    let m = self.manifest(&d)?.ok_or_else(|| {
                        anyhow!(Corrupt {
                            what: format!("artifact {}", short(&d)),
                            detail: "missing".into()
                        })
                    })?;
                    self.lay_out(m, &sub, copy)?;
                    out.push((name, sub));
                }
                Ok(Some(out))
            }
        }
    }

    /// Deletes an artifact's manifest so producers of it are recomputed.
    pub fn forget_artifact(&self, digest: &str) {
        let _ = fs::remove_file(self.tree_path(digest));
    }

    pub fn put_action(&self, rec: &ActionRecord) -> Result<()> {
        let body = serde_json::to_value(rec)?;
        let checksum = hash_bytes(body.to_string().as_bytes());
        let bytes = serde_json::to_vec_pretty(&Sealed { checksum, body })?;
        self.write_atomic(&self.action_path(&rec.key), &bytes)
    }

    /// `Ok(None)` = no record; `Err` = a record that fails its checksum (deleted).
    pub fn action(&self, key: &str) -> Result<Option<ActionRecord>, Corrupt> {
        let path = self.action_path(key);
        let Ok(bytes) = fs::read(&path) else {
            return Ok(None);
        };
        let bad = |detail: String| {
            let _ = fs::remove_file(&path);
            Corrupt {
                what: format!("action record {}", short(key)),
                detail,
            }
        };
        let sealed: Sealed<serde_json::Value> =
            serde_json::from_slice(&bytes).map_err(|e| bad(e.to_string()))?;
        if hash_bytes(sealed.body.to_string().as_bytes()) != sealed.checksum {
            return Err(bad("checksum mismatch".into()));
        }
        serde_json::from_value(sealed.body)
            .map(Some)
            .map_err(|e| bad(e.to_string()))
    }

    fn heads_path(&self, graph: &Path) -> PathBuf {
        let g = hash_bytes(graph.to_string_lossy().as_bytes());
        self.root.join("heads").join(format!("{}.json", &g[..16]))
    }

    fn read_heads(&self, graph: &Path) -> BTreeMap<String, BTreeMap<String, String>> {
        fs::read(self.heads_path(graph))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default()
    }

    /// Remembers the keys (per item) each node of a graph last ran with, for `explain`.
    pub fn set_heads(
        &self,
        graph: &Path,
        heads: BTreeMap<String, BTreeMap<String, String>>,
    ) -> Result<()> {
        let mut all = self.read_heads(graph);
        let before = all.clone();
        all.extend(heads);
        if all == before {
            return Ok(());
        }
        self.write_atomic(&self.heads_path(graph), &serde_json::to_vec(&all)?)
    }

    pub fn head(&self, graph: &Path, node: &str) -> Option<BTreeMap<String, String>> {
        self.read_heads(graph).remove(node)
    }

    /// A folder that outlives a run of action `key` until that action
    /// succeeds: a long node keeps its progress there, so a killed run resumes
    /// where it stopped. One per key (keys sharing a prefix must never resume
    /// from each other's progress); only the holder of the key's lock uses it.
    pub fn resume_dir(&self, key: &str) -> PathBuf {
        self.root.join("resume").join(hex2(key)).join(key)
    }

    /// An exclusive cross-process lock on a key while it is computed. One lock file
    /// per key: cluster jobs hold theirs for hours, and a job must never wait (holding
    /// its GPU) for an unrelated key that happens to share a lock.
    pub fn lock_key(&self, key: &str) -> Result<fs::File> {
        let path = self
            .root
            .join("locks")
            .join(hex2(key))
            .join(format!("{key}.lock"));
        self.ensure_parent(&path)?;
        lock_file(&path, "lock")
    }

    /// Content fingerprint of an input file or folder named by a path param.
    /// Files are hashed by content; folders by the (path, size, mtime) of every file,
    /// so a multi-gigabyte dataset folder is not read on every run. Links inside an
    /// input folder are followed (datasets are often assembled from links); names
    /// are hashed as the bytes the system stores, whatever they contain.
    pub fn fingerprint(path: &Path) -> Result<String> {
        let meta = fs::metadata(path)
            .with_context(|| format!("{}: no such file or folder", path.display()))?;
        if meta.is_file() {
            let mut h = blake3::Hasher::new();
            let file =
                fs::File::open(path).with_context(|| format!("{}: cannot read", path.display()))?;
            h.update_reader(file)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            return Ok(format!("file:{}", h.finalize().to_hex()));
        }
        let mut files = Vec::new();
        let mut seen = HashSet::new();
        input_files(path, &mut Vec::new(), &mut files, &mut seen)?;
        files.sort();
        let mut h = blake3::Hasher::new();
        for (rel, size, mtime) in files {
            h.update(&rel);
            h.update(format!("\0{size}\0{mtime}\n").as_bytes());
        }
        Ok(format!("dir:{}", h.finalize().to_hex()))
    }

    /// Fingerprint of files and folders a node reads that no path param names
    /// ([`crate::Node::reads`]): each by [`Store::fingerprint`]'s folder rule (size and
    /// modification time, never the contents), in the node's order, so a dataset's
    /// images are not read on every run but replacing one changes the key.
    pub fn fingerprint_reads(paths: &[PathBuf]) -> Result<String> {
        let mut h = blake3::Hasher::new();
        for path in paths {
            let meta = fs::metadata(path)
                .with_context(|| format!("{}: no such file or folder", path.display()))?;
            if meta.is_dir() {
                h.update(Store::fingerprint(path)?.as_bytes());
            } else {
                h.update(format!("file:{}:{}", meta.len(), mtime_nanos(&meta)).as_bytes());
            }
            h.update(b"\n");
        }
        Ok(format!("reads:{}", h.finalize().to_hex()))
    }
}

fn mtime_nanos(m: &fs::Metadata) -> u128 {
    m.modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos())
}

/// Every file below an input folder as (relative name bytes, size, mtime). Links are
/// followed; a folder reached twice (a link cycle) is walked once.
fn input_files(
    dir: &Path,
    prefix: &mut Vec<u8>,
    out: &mut Vec<(Vec<u8>, u64, u128)>,
    seen: &mut HashSet<PathBuf>,
) -> Result<()> {
    let canonical = dir
        .canonicalize()
        .with_context(|| format!("{}: cannot resolve", dir.display()))?;
    if !seen.insert(canonical) {
        return Ok(());
    }
    for e in fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))? {
        let e = e.with_context(|| format!("{}: cannot list", dir.display()))?;
        let p = e.path();
        // Follows links; a dangling one is reported by name.
        let meta = fs::metadata(&p)
            .with_context(|| format!("{}: cannot read (a link to nothing?)", p.display()))?;
        let len = prefix.len();
        if len > 0 {
            prefix.push(b'/');
        }
        prefix.extend_from_slice(e.file_name().as_encoded_bytes());
        if meta.is_dir() {
            input_files(&p, prefix, out, seen)?;
        } else {
            out.push((prefix.clone(), meta.len(), mtime_nanos(&meta)));
        }
        prefix.truncate(len);
    }
    Ok(())
}

/// A manifest's file path must already be in the checked, normalised form.
fn check_manifest_path(path: &str, digest: &str) -> Result<(), Corrupt> {
    match crate::paths::normalise_relative(path) {
        Ok(n) if n == path => Ok(()),
        _ => Err(Corrupt {
            what: format!("artifact {}", short(digest)),
            detail: format!("file path {path:?} is not a plain relative path"),
        }),
    }
}

impl Drop for Store {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.tmp);
        let _ = fs::remove_file(self.tmp.with_extension("lock"));
    }
}

/// `<pid>-<nanos>`: the staging folder names [`Store::open`] makes.
fn is_staging_name(name: &str) -> bool {
    name.split_once('-').is_some_and(|(pid, n)| {
        !pid.is_empty()
            && !n.is_empty()
            && pid.bytes().all(|b| b.is_ascii_digit())
            && n.bytes().all(|b| b.is_ascii_digit())
    })
}

fn unique_suffix() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

pub fn short(h: &str) -> &str {
    &h[..12.min(h.len())]
}

/// The files of an output folder as `/`-separated relative names. Every component
/// passes [`crate::paths::check_component`] (so no name means something else on
/// another platform); links and special files are refused, never followed.
fn output_files(root: &Path, dir: &Path, out: &mut Vec<String>) -> Result<()> {
    for e in fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))? {
        let e = e?;
        let p = e.path();
        let name = e.file_name();
        let name = name
            .to_str()
            .ok_or_else(|| anyhow!("{}: file name is not UTF-8", p.display()))?;
        crate::paths::check_component(name)
            .map_err(|why| anyhow!("{}: output {why}", dir.display()))?;
        let ft = e.file_type()?;
        if ft.is_dir() {
            output_files(root, &p, out)?;
        } else if ft.is_file() {
            let rel = p.strip_prefix(root).expect("walked below root");
            let parts: Vec<&str> = rel
                .components()
                .map(|c| {
                    c.as_os_str()
                        .to_str()
                        .expect("every component checked as UTF-8")
                })
                .collect();
            out.push(parts.join("/"));
        } else if ft.is_symlink() {
            bail!("{}: outputs must be plain files, not links", p.display());
        } else {
            bail!("{}: outputs must be plain files", p.display());
        }
    }
    Ok(())
}

/// Blobs are read-only, so the hard links that hand them to nodes as inputs cannot be
/// written through: a write fails instead of changing the cache. (Root ignores the mode;
/// a blob changed anyway fails its hash check when a later run reads it, and is
/// recomputed.) Copies are made writable again. Elsewhere than Unix a read-only file
/// cannot be deleted by `gc`, so modes are left alone there.
/// Copies a file that may be a (read-only) blob or an input into a file of its own that
/// its owner can change: what users get under OUT, and what a node hands to a program
/// that may edit its copy.
pub fn copy_writable(from: &Path, to: &Path) -> Result<()> {
    fs::copy(from, to)
        .with_context(|| format!("{}: cannot copy to {}", from.display(), to.display()))?;
    set_writable(to, true)
}

#[cfg(unix)]
fn set_writable(path: &Path, writable: bool) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    let mode = if writable { 0o644 } else { 0o444 };
    fs::set_permissions(path, fs::Permissions::from_mode(mode))
        .with_context(|| format!("{}: cannot set permissions", path.display()))
}

#[cfg(not(unix))]
fn set_writable(_path: &Path, _writable: bool) -> Result<()> {
    Ok(())
}

/// Opens (creating if missing, never truncating) the lock file at `path` and waits for
/// its exclusive lock, held until the file is dropped. `what` names it in the open error.
pub(crate) fn lock_file(path: &Path, what: &str) -> Result<fs::File> {
    let f = fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .with_context(|| format!("{}: cannot open {what}", path.display()))?;
    f.lock()
        .with_context(|| format!("{}: cannot lock", path.display()))?;
    Ok(f)
}
