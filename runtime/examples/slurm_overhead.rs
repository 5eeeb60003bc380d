//! What `--executor slurm` costs per item, and what the coordinator costs, on a real
//! Slurm cluster (for the numbers in docs/cluster.md and docs/benchmarks.md).
//!
//!     cargo run --release -p objectsplat-runtime --example slurm_overhead -- run N
//!     cargo run --release -p objectsplat-runtime --example slurm_overhead -- hold N
//!
//! The graph: `spread` makes a collection of N items, `touch` fans out over it and
//! writes one small file per item (nothing to compute: what is left is overhead). The
//! jobs run this very program (`run-action SPEC`), which rebuilds the same plan.
//!
//! `run N`: the fan-out computed locally (`-j 2`) and then as Slurm jobs, into two
//! caches; prints wall times, submit-to-done seconds per item (the report's item
//! times and waits together), and the coordinator's CPU time (its own threads, and
//! the `sbatch`/`squeue` it started).
//! `hold N`: the coordinator's side at scale without running N jobs: the arrays are
//! submitted held (`--hold`), so the run plans, claims, writes N task files and
//! submits; once `squeue` lists all N tasks the program interrupts itself (SIGINT, as
//! Ctrl-C) and the coordinator cancels them. Prints the time and CPU to get N tasks
//! queued, one `squeue` over them, and the cancellation.

use anyhow::{Result, bail};
use objectsplat_runtime::exec::{self, Executor, Local, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{Plan, build_plan};
use objectsplat_runtime::report::RunReport;
use objectsplat_runtime::slurm::{SlurmConfig, worker};
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry};
use std::path::Path;
use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod bench_graph;

struct Spread;
impl Node for Spread {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("spread", "1")
            .output("out", "[Num]", "")
            .param("count", ParamType::int(), Some("1"), "")
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let out = ctx.output("out")?;
        for i in 0..ctx.param::<i64>("count")? {
            let item = out.join(format!("i{i:06}"));
            std::fs::create_dir_all(&item)?;
            std::fs::write(item.join("v"), i.to_string())?;
        }
        Ok(Outcome::Done)
    }
}

struct Touch;
impl Node for Touch {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("touch", "1")
            .input("x", "Num", "")
            .output("out", "Num", "")
            .param("salt", ParamType::int(), Some("0"), "")
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let v: i64 = std::fs::read_to_string(ctx.input("x")?.join("v"))?.parse()?;
        let salt: i64 = ctx.param("salt")?;
        std::fs::write(ctx.output("out")?.join("v"), (v + salt).to_string())?;
        Ok(Outcome::Done)
    }
}

fn registry() -> Result<Registry> {
    bench_graph::registry(vec![Arc::new(Spread), Arc::new(Touch)])
}

fn plan(graph: &Path) -> Result<Plan> {
    Ok(build_plan(
        &GraphSource::read(graph)?,
        &registry()?,
        &[],
        &[],
    )?)
}

/// (user + system seconds of this process, of its waited-for children).
fn cpu_seconds() -> (f64, f64) {
    let get = |who| {
        // SAFETY: getrusage fills the zeroed struct it is given.
        let mut r: libc::rusage = unsafe { std::mem::zeroed() };
        unsafe { libc::getrusage(who, &mut r) };
        let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 * 1e-6;
        t(r.ru_utime) + t(r.ru_stime)
    };
    (get(libc::RUSAGE_SELF), get(libc::RUSAGE_CHILDREN))
}

fn slurm(worker_args: Vec<&str>, hold: bool) -> Result<SlurmConfig> {
    let exe = std::env::current_exe()?;
    let mut cfg = SlurmConfig::new(
        std::iter::once(exe.into_os_string())
            .chain(worker_args.iter().map(Into::into))
            .collect(),
    );
    cfg.poll = Duration::from_secs(2);
    cfg.settings.job_name = Some("osbench".into());
    if hold {
        cfg.settings.args.push("--hold".into());
    }
    Ok(cfg)
}

fn run_graph(
    dir: &Path,
    n: usize,
    cache: &str,
    executor: &dyn Executor,
) -> Result<(RunReport, f64)> {
    let graph = dir.join("bench.ron");
    std::fs::write(
        &graph,
        format!(
            "(nodes: {{\n  \"spread\": (kind: \"spread\", params: (count: {n})),\n  \"touch\": (kind: \"touch\", inputs: (x: each(\"spread.out\"))),\n}})\n"
        ),
    )?;
    let plan = plan(&graph)?;
    let store = Store::open(&dir.join(cache))?;
    let opts = RunOptions {
        jobs: 2,
        threads_per_job: None,
        out_dir: None,
        observer: Arc::new(Silent),
    };
    // The collection first, so that only the fan-out is timed.
    let mut upstream = plan.clone();
    upstream.targets = vec![plan.index("spread").expect("the graph has spread")];
    exec::run(&upstream, &store, &opts)?;
    let t0 = Instant::now();
    let report = exec::run_on(&plan, &store, &opts, executor)?;
    Ok((report, t0.elapsed().as_secs_f64()))
}

fn squeue_count() -> usize {
    Command::new("squeue")
        .args(["-h", "-r", "-n", "osbench-touch", "-o", "%i"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).lines().count())
        .unwrap_or(0)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("run-action") {
        let code = worker::run_action(Path::new(&args[2]), |spec| plan(&spec.graph));
        std::process::exit(code);
    }
    let mode = args.get(1).map(String::as_str).unwrap_or("run");
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(100);
    let dir = tempfile::tempdir_in(std::env::current_dir()?)?;
    match mode {
        "run" => {
            let (local, t_local) = run_graph(dir.path(), n, "cache-local", &Local)?;
            let cpu0 = cpu_seconds();
            let (report, t) = run_graph(
                dir.path(),
                n,
                "cache-slurm",
                &slurm(vec!["run-action"], false)?,
            )?;
            let cpu1 = cpu_seconds();
            if !report.ok || !local.ok {
                bail!("a run failed: {:?}", report.first_failure());
            }
            let touch = report.node("touch").expect("touch ran");
            // Submit to done: the item's own run and its wait (Slurm's queue, the job's
            // start, collecting the result), which the report keeps apart.
            let mut secs: Vec<f64> = touch
                .items
                .iter()
                .map(|i| i.seconds + i.queued_seconds)
                .collect();
            secs.sort_by(f64::total_cmp);
            let pct = |p: f64| secs[((secs.len() - 1) as f64 * p).round() as usize];
            println!("items: {n}");
            println!(
                "local fan-out (-j 2): {t_local:.2} s wall, {:.1} ms per item",
                t_local * 1e3 / n as f64
            );
            println!(
                "slurm fan-out: {t:.2} s wall, {:.1} ms per item",
                t * 1e3 / n as f64
            );
            println!(
                "submit-to-done per item: median {:.2} s, p10 {:.2} s, p90 {:.2} s, max {:.2} s",
                pct(0.5),
                pct(0.1),
                pct(0.9),
                pct(1.0)
            );
            println!(
                "coordinator CPU: {:.2} s own ({:.2} ms per item), {:.2} s in sbatch/squeue/sacct",
                cpu1.0 - cpu0.0,
                (cpu1.0 - cpu0.0) * 1e3 / n as f64,
                cpu1.1 - cpu0.1
            );
        }
        "hold" => {
            let cpu0 = cpu_seconds();
            let t0 = Instant::now();
            let done = Arc::new(std::sync::atomic::AtomicBool::new(false));
            let run_ended = done.clone();
            let watcher = std::thread::spawn(move || -> (f64, f64, (f64, f64)) {
                loop {
                    std::thread::sleep(Duration::from_millis(500));
                    if run_ended.load(std::sync::atomic::Ordering::SeqCst) {
                        // The run ended before all tasks were queued (sbatch refused some).
                        return (f64::NAN, f64::NAN, cpu_seconds());
                    }
                    let q0 = Instant::now();
                    if squeue_count() >= n {
                        let queued = t0.elapsed().as_secs_f64();
                        let one_squeue = q0.elapsed().as_secs_f64();
                        let cpu = cpu_seconds();
                        // SAFETY: sends SIGINT to this process, as Ctrl-C would.
                        unsafe { libc::kill(libc::getpid(), libc::SIGINT) };
                        return (queued, one_squeue, cpu);
                    }
                }
            });
            let result = run_graph(
                dir.path(),
                n,
                "cache-hold",
                &slurm(vec!["run-action"], true)?,
            );
            done.store(true, std::sync::atomic::Ordering::SeqCst);
            let t_stop = t0.elapsed().as_secs_f64();
            let (queued, one_squeue, cpu_q) = watcher.join().expect("the watcher does not panic");
            let cpu1 = cpu_seconds();
            let mut left = squeue_count();
            let c0 = Instant::now();
            while left > 0 && c0.elapsed() < Duration::from_secs(120) {
                std::thread::sleep(Duration::from_millis(200));
                left = squeue_count();
            }
            println!("items: {n} (held)");
            println!(
                "all {n} tasks queued after {queued:.2} s; coordinator CPU until then {:.2} s own ({:.3} ms per item) + {:.2} s children (squeue polls of the watcher included)",
                cpu_q.0 - cpu0.0,
                (cpu_q.0 - cpu0.0) * 1e3 / n as f64,
                cpu_q.1 - cpu0.1
            );
            println!("one squeue -r over the {n} tasks: {one_squeue:.2} s");
            println!(
                "interrupted: run returned after {:.2} s more ({}), coordinator CPU {:.2} s own; {left} tasks still listed {:.1} s later",
                t_stop - queued,
                match &result {
                    Ok(_) => "ok?".to_string(),
                    Err(e) => format!("{e:#}").chars().take(60).collect(),
                },
                cpu1.0 - cpu_q.0,
                c0.elapsed().as_secs_f64()
            );
        }
        other => bail!("unknown mode {other:?}; expected run or hold"),
    }
    Ok(())
}
