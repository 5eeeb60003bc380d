//! Claims: "run R has (or is about to have) a job computing key K", so a second
//! coordinator on the same cache waits for that job instead of queueing its own.
//!
//! A claim is created whole or not at all (written aside, then hard-linked into place,
//! which fails when one exists: atomic on local filesystems and on NFS alike) and
//! replaced by rename. A claim whose job died is taken over by renaming it away, which
//! only one coordinator can do. The remaining races (a claim taken over just as its
//! owner resubmits) can start a second job for a key, never a second computation: the
//! job takes the key's lock and checks the cache first.

use anyhow::{Context as _, Result};
use serde::{Deserialize, Serialize};
use std::fs;
use std::io::ErrorKind;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Claim {
    /// The claiming coordinator's run id.
    pub run: String,
    /// Its job for the key, once submitted (`<array>_<task>`).
    pub job: Option<String>,
    /// Unix seconds when claimed or last updated.
    pub since: u64,
}

pub enum Claimed {
    Mine,
    Theirs(Claim),
}

/// How long a claim without a job may stand before it counts as abandoned (its
/// coordinator died between claiming and submitting).
pub const UNSUBMITTED_TIMEOUT_S: u64 = 300;

pub struct Claims {
    dir: PathBuf,
    run: String,
    counter: AtomicU64,
}

fn now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

impl Claims {
    pub fn new(cache: &Path, run: &str) -> Claims {
        Claims {
            dir: cache.join("slurm").join("claims"),
            run: run.to_string(),
            counter: AtomicU64::new(0),
        }
    }

    fn path(&self, key: &str) -> PathBuf {
        self.dir
            .join(&key[..2.min(key.len())])
            .join(format!("{key}.json"))
    }

    /// A file with the claim's bytes beside its final place (same filesystem).
    fn write_aside(&self, key: &str, claim: &Claim) -> Result<PathBuf> {
        let path = self.path(key);
        let parent = path.parent().expect("a claim path has a folder");
        fs::create_dir_all(parent)
            .with_context(|| format!("{}: cannot create", parent.display()))?;
        let n = self.counter.fetch_add(1, Ordering::Relaxed);
        let tmp = parent.join(format!(".{key}.{}.{n}.tmp", self.run));
        // Serialising strings and numbers cannot fail.
        let bytes = serde_json::to_vec(claim).unwrap_or_default();
        fs::write(&tmp, bytes).with_context(|| format!("{}: cannot write", tmp.display()))?;
        Ok(tmp)
    }

    /// The claim on `key`, if any (an unreadable one counts as an anonymous claim
    /// made now: better to wait a while than to queue a duplicate).
    pub fn read(&self, key: &str) -> Option<Claim> {
        let bytes = fs::read(self.path(key)).ok()?;
        Some(serde_json::from_slice(&bytes).unwrap_or(Claim {
            run: "?".into(),
            job: None,
            since: now(),
        }))
    }

    /// Claims `key` for this run unless another run holds it.
    pub fn claim(&self, key: &str) -> Result<Claimed> {
        let mine = Claim {
            run: self.run.clone(),
            job: None,
            since: now(),
        };
        // A claim released between a failed link and the read is tried again.
        for _ in 0..3 {
            let tmp = self.write_aside(key, &mine)?;
            let linked = fs::hard_link(&tmp, self.path(key));
            let _ = fs::remove_file(&tmp);
            match linked {
                Ok(()) => return Ok(Claimed::Mine),
                Err(e) if e.kind() == ErrorKind::AlreadyExists => match self.read(key) {
                    Some(c) if c.run == self.run => return Ok(Claimed::Mine),
                    Some(c) => return Ok(Claimed::Theirs(c)),
                    None => continue,
                },
                Err(e) => {
                    return Err(e)
                        .with_context(|| format!("{}: cannot claim", self.path(key).display()));
                }
            }
        }
        anyhow::bail!(
            "{}: claimed and released over and over by other runs",
            self.path(key).display()
        )
    }

    /// Records this run's job for a key it holds; `false` when the claim is no
    /// longer this run's (another coordinator took it over).
    pub fn set_job(&self, key: &str, job: &str) -> bool {
        if self.read(key).is_none_or(|c| c.run != self.run) {
            return false;
        }
        let claim = Claim {
            run: self.run.clone(),
            job: Some(job.to_string()),
            since: now(),
        };
        match self.write_aside(key, &claim) {
            Ok(tmp) => fs::rename(&tmp, self.path(key)).is_ok(),
            Err(_) => false,
        }
    }

    /// Gives up this run's claim (the key is done, failed, or the run is cancelled).
    pub fn release(&self, key: &str) {
        if self.read(key).is_some_and(|c| c.run == self.run) {
            let _ = fs::remove_file(self.path(key));
        }
    }

    /// Takes over a claim whose job died; only one of several coordinators trying at
    /// once succeeds (the rename).
    pub fn take_over(&self, key: &str) -> Result<Claimed> {
        let path = self.path(key);
        let aside = path.with_extension(format!("taken-by-{}", self.run));
        if fs::rename(&path, &aside).is_ok() {
            let _ = fs::remove_file(&aside);
        }
        self.claim(key)
    }

    /// Whether a claim without a job has stood too long to be believed.
    pub fn abandoned(claim: &Claim) -> bool {
        claim.job.is_none() && now().saturating_sub(claim.since) > UNSUBMITTED_TIMEOUT_S
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_claim_per_key_and_only_the_owner_updates_or_releases_it() {
        let dir = tempfile::tempdir().unwrap();
        let a = Claims::new(dir.path(), "run-a");
        let b = Claims::new(dir.path(), "run-b");
        let key = "ab12cd";
        assert!(matches!(a.claim(key).unwrap(), Claimed::Mine));
        // A second claim by the owner is still its own; another run sees the owner's.
        assert!(matches!(a.claim(key).unwrap(), Claimed::Mine));
        match b.claim(key).unwrap() {
            Claimed::Theirs(c) => assert_eq!((c.run.as_str(), c.job), ("run-a", None)),
            Claimed::Mine => panic!("two runs hold one claim"),
        }
        assert!(a.set_job(key, "17_3"));
        assert!(!b.set_job(key, "18_0"), "only the owner names the job");
        b.release(key);
        assert_eq!(a.read(key).unwrap().job.as_deref(), Some("17_3"));
        // Taking over hands the claim to the new run, and the old owner can no longer
        // update or release it.
        assert!(matches!(b.take_over(key).unwrap(), Claimed::Mine));
        assert!(!a.set_job(key, "17_4"));
        a.release(key);
        assert_eq!(b.read(key).unwrap().run, "run-b");
        b.release(key);
        assert!(a.read(key).is_none());
        assert!(matches!(a.claim(key).unwrap(), Claimed::Mine));
    }
}
