//! The whole-run line: how much of a run is done and how long the rest will take, from the
//! jobs the scheduler queued and the progress units they report. Nothing here knows what a
//! kind of work is: the units of one `what` (`training`, `rendering`) are summed over the
//! run's jobs and timed, and a queued job that has not reported yet is expected to do as
//! much as the jobs of its node that have.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::{Duration, Instant};

/// One job's latest report of a kind of work.
struct Work {
    what: String,
    done: u64,
    total: u64,
    /// `done` at its first report: units done before this run (a job resuming saved
    /// progress) are not this run's rate.
    first_done: u64,
}

struct Job {
    node: String,
    finished: bool,
    work: Option<Work>,
}

/// One kind of work over the run.
#[derive(Debug, Clone, PartialEq)]
pub struct KindSummary {
    pub what: String,
    /// Units the run's jobs reported done.
    pub done: u64,
    /// Units the jobs reported, plus what the queued jobs that have not reported yet are
    /// expected to do.
    pub total: u64,
}

/// Where the run stands.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Jobs finished and jobs queued (cache misses; what the cache answered is no job).
    pub jobs_done: usize,
    pub jobs_total: usize,
    /// Kinds of work with units left, by name.
    pub kinds: Vec<KindSummary>,
    pub elapsed: Duration,
    /// Time left for the units left, at the rate each kind has gone so far; `None` while
    /// a kind with units left has not been measured yet.
    pub eta: Option<Duration>,
}

pub struct RunProgress {
    started: Instant,
    jobs: BTreeMap<String, Job>,
    /// When each kind was first reported.
    first_report: BTreeMap<String, Instant>,
}

impl RunProgress {
    pub fn new(started: Instant) -> RunProgress {
        RunProgress {
            started,
            jobs: BTreeMap::new(),
            first_report: BTreeMap::new(),
        }
    }

    pub fn queued(&mut self, job: &str, node: &str) {
        self.jobs.insert(
            job.to_string(),
            Job {
                node: node.to_string(),
                finished: false,
                work: None,
            },
        );
    }

    pub fn progress(&mut self, job: &str, done: u64, total: u64, what: &str, now: Instant) {
        self.first_report.entry(what.to_string()).or_insert(now);
        let job = self.jobs.entry(job.to_string()).or_insert(Job {
            node: String::new(),
            finished: false,
            work: None,
        });
        match &mut job.work {
            Some(w) if w.what == what => (w.done, w.total) = (done, total),
            work => {
                *work = Some(Work {
                    what: what.to_string(),
                    done,
                    total,
                    first_done: done,
                })
            }
        }
    }

    /// A finished job did all the work it was going to: an early stop shrinks its total.
    pub fn finished(&mut self, job: &str) {
        if let Some(job) = self.jobs.get_mut(job) {
            job.finished = true;
            if let Some(w) = &mut job.work {
                w.total = w.done;
            }
        }
    }

    /// What a job of each node that has not reported is expected to do: the kind its
    /// node's reporting jobs do most often, and their mean total.
    fn expected_per_node(&self) -> BTreeMap<&str, (&str, u64)> {
        let mut totals: BTreeMap<(&str, &str), Vec<u64>> = BTreeMap::new();
        for job in self.jobs.values() {
            if let Some(w) = &job.work {
                totals
                    .entry((job.node.as_str(), w.what.as_str()))
                    .or_default()
                    .push(w.total);
            }
        }
        let mut expected: BTreeMap<&str, (&str, u64, usize)> = BTreeMap::new();
        for ((node, what), t) in totals {
            let mean = t.iter().sum::<u64>() / t.len() as u64;
            match expected.get(node) {
                Some(&(_, _, jobs)) if jobs >= t.len() => {}
                _ => {
                    expected.insert(node, (what, mean, t.len()));
                }
            }
        }
        expected
            .into_iter()
            .map(|(node, (what, mean, _))| (node, (what, mean)))
            .collect()
    }

    pub fn summary(&self, now: Instant) -> Summary {
        let expected = self.expected_per_node();
        let mut kinds: BTreeMap<&str, (u64, u64, u64)> = BTreeMap::new();
        for job in self.jobs.values() {
            match &job.work {
                Some(w) => {
                    let k = kinds.entry(&w.what).or_default();
                    k.0 += w.done;
                    k.1 += w.total;
                    k.2 += w.done.saturating_sub(w.first_done);
                }
                None if !job.finished => {
                    if let Some(&(what, total)) = expected.get(job.node.as_str()) {
                        kinds.entry(what).or_default().1 += total;
                    }
                }
                None => {}
            }
        }
        let mut eta = Some(Duration::ZERO);
        let mut left = Vec::new();
        for (what, (done, total, this_run)) in kinds {
            if done >= total {
                continue;
            }
            let seconds = self
                .first_report
                .get(what)
                .map_or(0.0, |t| now.saturating_duration_since(*t).as_secs_f64());
            let rate = (this_run > 0 && seconds > 0.0).then(|| this_run as f64 / seconds);
            eta = match (eta, rate) {
                (Some(sum), Some(rate)) => {
                    Some(sum + Duration::from_secs_f64((total - done) as f64 / rate))
                }
                _ => None,
            };
            left.push(KindSummary {
                what: what.to_string(),
                done,
                total,
            });
        }
        Summary {
            jobs_done: self.jobs.values().filter(|j| j.finished).count(),
            jobs_total: self.jobs.len(),
            kinds: left,
            elapsed: now.saturating_duration_since(self.started),
            eta,
        }
    }

    /// `3/9 items · training 2150/9000 · 1m12s · ETA 3m40s`
    pub fn line(&self, now: Instant) -> String {
        let s = self.summary(now);
        let mut line = format!("{}/{} items", s.jobs_done, s.jobs_total);
        for k in &s.kinds {
            let _ = write!(line, " · {} {}/{}", k.what, k.done, k.total);
        }
        let _ = write!(line, " · {}", clock(s.elapsed));
        if !s.kinds.is_empty() {
            match s.eta {
                Some(eta) => {
                    let _ = write!(line, " · ETA {}", clock(eta));
                }
                None => line.push_str(" · ETA …"),
            }
        }
        line
    }
}

/// `45s`, `3m40s`, `2h05m`.
fn clock(d: Duration) -> String {
    let s = d.as_secs();
    match s {
        0..60 => format!("{s}s"),
        60..3600 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(start: Instant, seconds: u64) -> Instant {
        start + Duration::from_secs(seconds)
    }

    #[test]
    fn sums_units_per_kind_and_estimates_queued_jobs_from_their_node() {
        let t0 = Instant::now();
        let mut p = RunProgress::new(t0);
        for item in ["a", "b", "c"] {
            p.queued(&format!("objects[{item}]"), "objects");
        }
        p.queued("scene", "scene");
        p.finished("scene");
        // Two items train side by side, 100 iterations per second together.
        p.progress("objects[a]", 0, 1000, "training", t0);
        p.progress("objects[b]", 0, 1000, "training", t0);
        p.progress("objects[a]", 500, 1000, "training", at(t0, 10));
        p.progress("objects[b]", 500, 1000, "training", at(t0, 10));
        let s = p.summary(at(t0, 10));
        assert_eq!((s.jobs_done, s.jobs_total), (1, 4));
        // Item c has not started: it is expected to train as long as a and b.
        assert_eq!(
            s.kinds,
            [KindSummary {
                what: "training".into(),
                done: 1000,
                total: 3000
            }]
        );
        assert_eq!(s.eta, Some(Duration::from_secs(20)));
        assert_eq!(
            p.line(at(t0, 10)),
            "1/4 items · training 1000/3000 · 10s · ETA 20s"
        );
    }

    #[test]
    fn an_early_stop_shrinks_the_work_and_resumed_units_are_not_this_runs_rate() {
        let t0 = Instant::now();
        let mut p = RunProgress::new(t0);
        p.queued("train[a]", "train");
        p.queued("train[b]", "train");
        p.progress("train[a]", 200, 1000, "training", t0);
        p.progress("train[a]", 300, 1000, "training", at(t0, 100));
        p.finished("train[a]");
        // a stopped early at 300: b is expected to do as much, at 1 iteration per second
        // (a resumed at 200, so only 100 of its units were this run's).
        let s = p.summary(at(t0, 100));
        assert_eq!((s.kinds[0].done, s.kinds[0].total), (300, 600));
        assert_eq!(s.eta, Some(Duration::from_secs(300)));
    }

    #[test]
    fn no_eta_before_a_kind_is_measured_and_none_without_work_left() {
        let t0 = Instant::now();
        let mut p = RunProgress::new(t0);
        p.queued("render", "render");
        p.progress("render", 0, 7, "rendering", at(t0, 5));
        assert_eq!(p.line(at(t0, 5)), "0/1 items · rendering 0/7 · 5s · ETA …");
        p.progress("render", 7, 7, "rendering", at(t0, 65));
        p.finished("render");
        assert_eq!(p.line(at(t0, 65)), "1/1 items · 1m05s");
        assert_eq!(p.summary(at(t0, 65)).eta, Some(Duration::ZERO));
        assert_eq!(clock(Duration::from_secs(7500)), "2h05m");
    }
}
