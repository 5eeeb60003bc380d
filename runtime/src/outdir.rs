//! Writing targets' outputs under `--out`.
//!
//! Two runs may share one `--out` (a second terminal, a script): the folder is
//! locked while outputs are written (`OUT/.objectsplat-lock`), so the runs take turns
//! and the last one leaves a whole set. Each `OUT/<node>/<port>` is laid out in a
//! staging folder inside `OUT` first and then renamed into place, so a killed run
//! leaves the previous outputs or the new ones, never a mix within a port; its
//! staging folder is removed by the next run. Links are never written through:
//! an `OUT/<node>` that is a link is refused, and a link at `OUT/<node>/<port>` is
//! replaced (the link, not what it points to).

use crate::store::{self, Corrupt, Store};
use anyhow::{Context as _, Result, anyhow, bail};
use std::fs;
use std::path::Path;

pub const LOCK_FILE: &str = ".objectsplat-lock";
const STAGING_PREFIX: &str = ".objectsplat-staging-";

/// Held while a run writes into `--out`; released on drop.
pub struct OutLock {
    _file: fs::File,
}

/// Creates `out` if needed and waits for its lock (another run may be writing it).
pub fn lock(out: &Path) -> Result<OutLock> {
    fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let file = store::lock_file(&out.join(LOCK_FILE), "the output lock")?;
    Ok(OutLock { _file: file })
}

/// One target output: `OUT/<node>/<port>` gets the artifact `digest`.
pub struct TargetOutput<'a> {
    pub node: &'a str,
    pub port: &'a str,
    pub digest: &'a str,
}

/// Writes every target output, or none: all are laid out (and every blob verified)
/// in a staging folder before the first one replaces its predecessor. Corrupt
/// artifacts are all reported together (and forgotten, so their producers rerun).
pub fn write_targets(store: &Store, out: &Path, targets: &[TargetOutput]) -> Result<()> {
    let _lock = lock(out)?;
    remove_stale_staging(out);
    let staging = out.join(format!(
        "{STAGING_PREFIX}{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    fs::create_dir(&staging).with_context(|| format!("{}: cannot create", staging.display()))?;
    let result = stage_and_swap(store, out, &staging, targets);
    let _ = fs::remove_dir_all(&staging);
    result
}

fn stage_and_swap(
    store: &Store,
    out: &Path,
    staging: &Path,
    targets: &[TargetOutput],
) -> Result<()> {
    let new = staging.join("new");
    let old = staging.join("old");
    fs::create_dir_all(&old)?;
    let mut corrupt = Vec::new();
    for t in targets {
        check_name(t.node)?;
        check_name(t.port)?;
        let dest = new.join(t.node).join(t.port);
        if let Err(e) = store.materialize(t.digest, &dest, true) {
            match e.downcast_ref::<Corrupt>() {
                Some(c) => {
                    store.forget_artifact(t.digest);
                    corrupt.push(format!("{}.{}: {c}", t.node, t.port));
                }
                None => return Err(e),
            }
        }
    }
    if !corrupt.is_empty() {
        return Err(anyhow!(Corrupt {
            what: format!("{} target output(s)", corrupt.len()),
            detail: corrupt.join("; "),
        }));
    }
    for t in targets {
        let node_dir = out.join(t.node);
        match fs::symlink_metadata(&node_dir) {
            Ok(m) if m.file_type().is_symlink() => bail!(
                "{}: is a link; objectsplat writes only real folders under --out (remove the link)",
                node_dir.display()
            ),
            Ok(m) if !m.is_dir() => bail!(
                "{}: is a file, not the folder of node `{}`'s outputs (remove it)",
                node_dir.display(),
                t.node
            ),
            Ok(_) => {}
            Err(_) => fs::create_dir(&node_dir)
                .with_context(|| format!("{}: cannot create", node_dir.display()))?,
        }
        let dest = node_dir.join(t.port);
        if fs::symlink_metadata(&dest).is_ok() {
            // Renaming moves a link itself, never its target.
            fs::rename(&dest, old.join(format!("{}.{}", t.node, t.port)))
                .with_context(|| format!("{}: cannot replace", dest.display()))?;
        }
        fs::rename(new.join(t.node).join(t.port), &dest)
            .with_context(|| format!("{}: cannot write", dest.display()))?;
    }
    Ok(())
}

/// Node ids and port names become folder names here; both are checked when the
/// graph and the node kinds are, so a failure is a bug, reported rather than trusted.
fn check_name(name: &str) -> Result<()> {
    crate::paths::check_component(name).map_err(|e| anyhow!("cannot write outputs: {e}"))
}

/// Staging folders of runs that were killed while writing (the lock is ours, so no
/// live run owns one). Only names this module makes, only real folders.
fn remove_stale_staging(out: &Path) {
    let Ok(entries) = fs::read_dir(out) else {
        return;
    };
    for e in entries.flatten() {
        let ours = e
            .file_name()
            .to_str()
            .is_some_and(|n| n.starts_with(STAGING_PREFIX));
        if ours && e.file_type().is_ok_and(|t| t.is_dir()) {
            let _ = fs::remove_dir_all(e.path());
        }
    }
}
