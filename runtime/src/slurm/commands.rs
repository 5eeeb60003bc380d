//! The Slurm commands the coordinator uses: `sbatch`, `squeue`, `sacct`, `scancel`,
//! `scontrol`. Their output is parsed in the fixed, machine-readable forms Slurm
//! documents (`--parsable`, `-h -o FORMAT`, `sacct -P`).

use anyhow::{Context as _, Result, anyhow, bail};
use std::collections::HashMap;
use std::path::Path;
use std::process::{Command, Output};

/// What Slurm says about one job (an array task is a job `<array>_<task>`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JobState {
    /// `PENDING`, `RUNNING`, `COMPLETED`, `FAILED`, `PREEMPTED`, …
    pub state: String,
    /// The node it runs (or ran) on.
    pub node: Option<String>,
    /// Why it waits (`Resources`, `Priority`, …) or ended (`NonZeroExitCode`, …).
    pub reason: Option<String>,
}

impl JobState {
    /// Still queued or running: it may yet produce a result.
    pub fn alive(&self) -> bool {
        matches!(
            self.state.as_str(),
            "PENDING"
                | "CONFIGURING"
                | "RUNNING"
                | "COMPLETING"
                | "SUSPENDED"
                | "REQUEUED"
                | "REQUEUE_HOLD"
                | "REQUEUE_FED"
                | "RESIZING"
                | "SIGNALING"
                | "STAGE_OUT"
                | "STOPPED"
                | "RESV_DEL_HOLD"
                | "SPECIAL_EXIT"
        )
    }

    /// Ended in a way that running it again would end the same way.
    pub fn ends_again(&self) -> bool {
        matches!(
            self.state.as_str(),
            "TIMEOUT" | "OUT_OF_MEMORY" | "DEADLINE"
        )
    }
}

fn run(cmd: &mut Command) -> Result<Output> {
    let name = cmd.get_program().to_string_lossy().into_owned();
    cmd.output().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            anyhow!("`{name}` not found: --executor slurm needs the Slurm client commands on PATH")
        } else {
            anyhow!("cannot run `{name}`: {e}")
        }
    })
}

fn stderr_line(out: &Output) -> String {
    let text = String::from_utf8_lossy(&out.stderr);
    let text = text.trim();
    if text.is_empty() {
        format!("exit status {}", out.status)
    } else {
        crate::diag::bounded(text, 2000)
    }
}

/// Submits `script` with `args`; returns the job id (of the array, for `--array`).
pub fn sbatch(args: &[String], script: &Path) -> Result<String> {
    let out = run(Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .arg(script))?;
    if !out.status.success() {
        bail!("sbatch refused the job: {}", stderr_line(&out));
    }
    // `--parsable` prints `<id>` or `<id>;<cluster>`.
    let text = String::from_utf8_lossy(&out.stdout);
    let id = text.trim().split(';').next().unwrap_or("").trim();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        bail!("sbatch printed {text:?}, not a job id");
    }
    Ok(id.to_string())
}

/// The states of every task of these jobs (array ids or task ids) that slurmctld still
/// knows, finished ones included (for `MinJobAge` after they end). A job it has
/// forgotten is simply absent.
pub fn squeue(ids: &[String]) -> Result<HashMap<String, JobState>> {
    let mut states = HashMap::new();
    if ids.is_empty() {
        return Ok(states);
    }
    let out = run(Command::new("squeue")
        .args(["-h", "-r", "--states=all", "-o", "%i|%T|%N|%r", "-j"])
        .arg(ids.join(",")))?;
    if !out.status.success() {
        // Every id unknown: not an error, the jobs are gone.
        if String::from_utf8_lossy(&out.stderr).contains("Invalid job id") {
            return Ok(states);
        }
        bail!("squeue failed: {}", stderr_line(&out));
    }
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let f: Vec<&str> = line.split('|').map(str::trim).collect();
        if f.len() < 4 || f[0].is_empty() {
            continue;
        }
        let some = |s: &str| (!s.is_empty() && s != "(null)" && s != "None").then(|| s.to_string());
        states.insert(
            f[0].to_string(),
            JobState {
                state: f[1].to_string(),
                node: some(f[2]),
                reason: some(f[3]),
            },
        );
    }
    Ok(states)
}

/// How a job slurmctld no longer knows ended, from accounting; `None` when accounting
/// is off or does not know it either.
pub fn sacct(id: &str) -> Option<JobState> {
    let out = run(Command::new("sacct")
        .args([
            "-n",
            "-X",
            "-P",
            "-o",
            "JobID,State,NodeList,ExitCode",
            "-j",
        ])
        .arg(id))
    .ok()?;
    if !out.status.success() {
        return None;
    }
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|line| {
            let f: Vec<&str> = line.split('|').collect();
            (f.len() >= 4 && f[0] == id).then(|| JobState {
                // `CANCELLED by 0` → `CANCELLED`.
                state: f[1].split_whitespace().next().unwrap_or("").to_string(),
                node: (!f[2].is_empty() && f[2] != "None assigned").then(|| f[2].to_string()),
                reason: Some(format!("exit code {}", f[3])),
            })
        })
}

/// Cancels jobs; errors are reported, not fatal (a job may have ended meanwhile).
pub fn scancel(ids: &[String]) -> Result<()> {
    if ids.is_empty() {
        return Ok(());
    }
    let out = run(Command::new("scancel").args(ids))?;
    if !out.status.success() {
        bail!("scancel failed: {}", stderr_line(&out));
    }
    Ok(())
}

/// The largest array task index plus one (`MaxArraySize`, 1001 unless configured).
pub fn max_array_size() -> Result<usize> {
    let out = run(Command::new("scontrol").args(["show", "config"]))
        .context("asking slurmctld for MaxArraySize")?;
    if !out.status.success() {
        bail!("scontrol show config failed: {}", stderr_line(&out));
    }
    Ok(parse_max_array_size(&String::from_utf8_lossy(&out.stdout)).unwrap_or(1001))
}

fn parse_max_array_size(config: &str) -> Option<usize> {
    config.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == "MaxArraySize")
            .then(|| v.trim().parse().ok())
            .flatten()
    })
}

/// `0-3,7,9-10`: task indices for `--array`, consecutive runs folded.
pub fn array_ranges(indices: &[u32]) -> String {
    let mut sorted = indices.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut parts = Vec::new();
    let mut i = 0;
    while i < sorted.len() {
        let start = sorted[i];
        let mut end = start;
        while i + 1 < sorted.len() && sorted[i + 1] == end + 1 {
            i += 1;
            end = sorted[i];
        }
        parts.push(if start == end {
            start.to_string()
        } else {
            format!("{start}-{end}")
        });
        i += 1;
    }
    parts.join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn task_ranges_fold_consecutive_indices() {
        assert_eq!(array_ranges(&[0, 1, 2, 3]), "0-3");
        assert_eq!(array_ranges(&[9, 7, 0, 1, 10]), "0-1,7,9-10");
        assert_eq!(array_ranges(&[5]), "5");
    }

    #[test]
    fn max_array_size_is_read_from_the_config() {
        let cfg = "MailProg                = /bin/mail\nMaxArraySize            = 4001\nMaxJobCount = 10000\n";
        assert_eq!(parse_max_array_size(cfg), Some(4001));
        assert_eq!(parse_max_array_size("nothing"), None);
    }
}
