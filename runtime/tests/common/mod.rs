//! Test doubles: tiny numeric nodes whose runs are cheap and whose outputs are
//! predictable, so tests can assert exactly which jobs executed (the "execution log");
//! and the ways the tests run graphs of them (or of a kind of their own): in process, or
//! in a child process that can be killed.

#![allow(dead_code)]

use anyhow::{Result, bail};
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{self, Override, Plan};
use objectsplat_runtime::report::{RunReport, Status};
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{
    Context, DeclaredPorts, Node, NodeSpec, Outcome, ParamError, ParamType, Params, PortSpec,
    Registry, TypeRef,
};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;

pub fn read_num(dir: &Path) -> Result<i64> {
    Ok(std::fs::read_to_string(dir.join("value.txt"))?
        .trim()
        .parse()?)
}

pub fn write_num(dir: &Path, v: i64) -> Result<()> {
    std::fs::write(dir.join("value.txt"), v.to_string())?;
    Ok(())
}

struct Const;
impl Node for Const {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("const", "1").output("out", "Num", "").param(
            "value",
            ParamType::int(),
            Some("0"),
            "",
        )
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        write_num(&ctx.output("out")?, ctx.param("value")?)?;
        Ok(Outcome::Done)
    }
}

struct Add;
impl Node for Add {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("add", "1")
            .input("a", "Num", "")
            .optional_input("b", "Num", "")
            .output("out", "Num", "")
            .param("offset", ParamType::int(), Some("0"), "")
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let a = read_num(ctx.input("a")?)?;
        let b = match ctx.input_opt("b") {
            Some(d) => read_num(d)?,
            None => 0,
        };
        let off: i64 = ctx.param("offset")?;
        write_num(&ctx.output("out")?, a + b + off)?;
        Ok(Outcome::Done)
    }
}

/// `a % modulus`: changing the modulus can leave the output unchanged (early cutoff).
struct Modulo;
impl Node for Modulo {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("modulo", "1")
            .input("a", "Num", "")
            .output("out", "Num", "")
            .param(
                "modulus",
                ParamType::Int {
                    min: Some(1),
                    max: None,
                },
                Some("1000"),
                "",
            )
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let m: i64 = ctx.param("modulus")?;
        write_num(&ctx.output("out")?, read_num(ctx.input("a")?)? % m)?;
        Ok(Outcome::Done)
    }
}

/// A collection: one item per value.
struct Split;
impl Node for Split {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("split", "1")
            .output("items", "[Num]", "")
            .param("values", ParamType::list(ParamType::int()), None, "")
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let values: Vec<i64> = ctx.param("values")?;
        let out = ctx.output("items")?;
        for (i, v) in values.iter().enumerate() {
            let d = out.join(format!("item{i}"));
            std::fs::create_dir_all(&d)?;
            write_num(&d, *v)?;
        }
        Ok(Outcome::Done)
    }
}

struct Double;
impl Node for Double {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("double", "1")
            .input("x", "Num", "")
            .output("out", "Num", "")
            .param("sleep_ms", ParamType::int(), Some("0"), "")
            .param(
                "sleep_ms_per_unit",
                ParamType::int(),
                Some("0"),
                "extra sleep × x",
            )
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let x = read_num(ctx.input("x")?)?;
        let ms: u64 = ctx.param("sleep_ms")?;
        let per_unit: u64 = ctx.param("sleep_ms_per_unit")?;
        std::thread::sleep(std::time::Duration::from_millis(
            ms + per_unit * x.max(0) as u64,
        ));
        write_num(&ctx.output("out")?, 2 * x)?;
        ctx.note("doubled", format!("{x} → {}", 2 * x));
        Ok(Outcome::Done)
    }
}

struct Sum;
impl Node for Sum {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("sum", "1")
            .input("xs", "[Num]", "")
            .output("out", "Num", "")
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let mut s = 0;
        for (_, d) in ctx.input_items("xs")? {
            s += read_num(d)?;
        }
        write_num(&ctx.output("out")?, s)?;
        Ok(Outcome::Done)
    }
}

/// Fails (error or panic) when told to; otherwise copies its input.
struct Flaky;
impl Node for Flaky {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("flaky", "1")
            .input("a", "Num", "")
            .output("out", "Num", "")
            .param(
                "mode",
                ParamType::enumeration(&["ok", "error", "panic", "skip"]),
                Some("\"ok\""),
                "",
            )
            .param(
                "flag_file",
                ParamType::optional(ParamType::Str),
                Some("None"),
                "fail only while this file exists",
            )
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let flag: Option<String> = ctx.param("flag_file")?;
        let active = flag.map(|f| Path::new(&f).exists()).unwrap_or(true);
        match (ctx.param::<String>("mode")?.as_str(), active) {
            ("error", true) => bail!("flaky node failed on purpose"),
            ("panic", true) => panic!("flaky node panicked on purpose"),
            ("skip", true) => return Ok(Outcome::Skipped("nothing to do".into())),
            _ => {}
        }
        write_num(&ctx.output("out")?, read_num(ctx.input("a")?)?)?;
        Ok(Outcome::Done)
    }
}

/// The sum of the inputs its `terms` param declares (one `Num` input port per name):
/// the ports come from the graph, not from the kind.
struct SumOf;
impl Node for SumOf {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("sum_of", "1")
            .param("terms", ParamType::list(ParamType::Str), None, "")
            .param("term_type", ParamType::Str, Some("\"Num\""), "")
    }
    fn declared_ports(&self, params: &Params) -> Result<Option<DeclaredPorts>, ParamError> {
        let bad = |m: String| ParamError::new("terms", m);
        let terms: Vec<String> = params.get("terms").map_err(|e| bad(e.to_string()))?;
        let ty: String = params.get("term_type").map_err(|e| bad(e.to_string()))?;
        if terms.is_empty() {
            return Err(bad("declare at least one term".into()));
        }
        let port = |name: &str, ty: &str| PortSpec {
            name: name.into(),
            ty: TypeRef::One(ty.into()),
            optional: false,
            doc: String::new(),
        };
        Ok(Some(DeclaredPorts {
            inputs: terms.iter().map(|t| port(t, &ty)).collect(),
            outputs: vec![port("out", "Num")],
            inputs_param: "term_type".into(),
            outputs_param: "terms".into(),
        }))
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let terms: Vec<String> = ctx.param("terms")?;
        let mut total = 0;
        for t in &terms {
            total += read_num(ctx.input(t)?)?;
        }
        write_num(&ctx.output("out")?, total)?;
        Ok(Outcome::Done)
    }
}

/// `x × rate` over `steps`: a nested `schedule` map whose keys it checks before
/// anything runs (like a trainer's schedule overrides).
struct Tuned;
const TUNED_KEYS: [&str; 2] = ["rate", "steps"];
impl Node for Tuned {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("tuned", "1")
            .input("x", "Num", "")
            .output("out", "Num", "")
            .param(
                "schedule",
                ParamType::Ron("map of settings".into()),
                Some("{}"),
                "",
            )
            .param("label", ParamType::Str, Some("\"\""), "")
    }
    fn check_params(&self, params: &Params) -> Vec<ParamError> {
        let Ok(map) = params.get::<std::collections::BTreeMap<String, f64>>("schedule") else {
            return vec![ParamError::new("schedule", "expected a map of numbers")];
        };
        map.keys()
            .filter(|k| !TUNED_KEYS.contains(&k.as_str()))
            .map(|k| {
                ParamError::new(
                    "schedule",
                    format!(
                        "unknown setting `{k}`; settings are {}",
                        TUNED_KEYS.join(", ")
                    ),
                )
                .at([k])
            })
            .collect()
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let map: std::collections::BTreeMap<String, f64> = ctx.param("schedule")?;
        let rate = map.get("rate").copied().unwrap_or(1.0);
        let x = read_num(ctx.input("x")?)?;
        write_num(&ctx.output("out")?, (x as f64 * rate) as i64)?;
        Ok(Outcome::Done)
    }
}

pub fn registry() -> Registry {
    let mut reg = Registry::new();
    reg.add_type("Num", "a folder with value.txt");
    for n in [
        Arc::new(Const) as Arc<dyn Node>,
        Arc::new(Add),
        Arc::new(Modulo),
        Arc::new(Split),
        Arc::new(Double),
        Arc::new(Sum),
        Arc::new(Flaky),
        Arc::new(SumOf),
        Arc::new(Tuned),
    ] {
        reg.add_node(n).unwrap();
    }
    reg
}

pub struct Workspace {
    pub dir: tempfile::TempDir,
}

impl Workspace {
    pub fn new() -> Workspace {
        Workspace {
            dir: tempfile::tempdir().unwrap(),
        }
    }
    pub fn graph(&self, text: &str) -> PathBuf {
        let p = self.dir.path().join("g.ron");
        std::fs::write(&p, text).unwrap();
        p
    }
    /// Writes `text` to `data/<name>` beside the graph; returns the `data` folder.
    pub fn data_file(&self, name: &str, text: &str) -> PathBuf {
        let data = self.dir.path().join("data");
        std::fs::create_dir_all(&data).unwrap();
        std::fs::write(data.join(name), text).unwrap();
        data
    }
    pub fn cache(&self) -> PathBuf {
        self.dir.path().join("cache")
    }
    pub fn out(&self) -> PathBuf {
        self.dir.path().join("out")
    }
    pub fn run(&self, sets: &[&str]) -> RunReport {
        run_graph(
            &self.dir.path().join("g.ron"),
            &self.cache(),
            Some(&self.out()),
            sets,
            2,
        )
    }
    pub fn num(&self, node: &str, port: &str) -> i64 {
        read_num(&self.out().join(node).join(port)).unwrap()
    }
}

pub fn run_graph(
    graph: &Path,
    cache: &Path,
    out: Option<&Path>,
    sets: &[&str],
    jobs: usize,
) -> RunReport {
    execute(&plan_graph(graph, &registry(), sets, &[]), cache, out, jobs)
}

/// Plans the graph file at `graph` with `reg`'s kinds, `sets` (as `--set` would) and
/// `targets` (none: the graph's own), panicking with the diagnostics of a bad graph.
pub fn plan_graph(graph: &Path, reg: &Registry, sets: &[&str], targets: &[&str]) -> Plan {
    let src = GraphSource::read(graph).unwrap_or_else(|d| panic!("{d}"));
    let overrides: Vec<Override> = sets.iter().map(|s| Override::parse(s).unwrap()).collect();
    let targets: Vec<String> = targets.iter().map(|t| t.to_string()).collect();
    plan::build_plan(&src, reg, &overrides, &targets).unwrap_or_else(|d| panic!("{d}"))
}

/// Runs `plan` on `jobs` workers with the cache at `cache`, materializing into `out`.
pub fn execute(plan: &Plan, cache: &Path, out: Option<&Path>, jobs: usize) -> RunReport {
    let store = Store::open(cache).unwrap();
    exec::run(
        plan,
        &store,
        &RunOptions {
            jobs,
            threads_per_job: None,
            out_dir: out.map(Path::to_path_buf),
            observer: Arc::new(Silent),
        },
    )
    .unwrap()
}

/// A node kind of one test's own: its spec, and the function that does a run.
pub fn fn_kind(spec: NodeSpec, run: fn(&mut Context) -> Result<Outcome>) -> Arc<dyn Node> {
    Arc::new(FnKind { spec, run })
}

struct FnKind {
    spec: NodeSpec,
    run: fn(&mut Context) -> Result<Outcome>,
}

impl Node for FnKind {
    fn spec(&self) -> NodeSpec {
        self.spec.clone()
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        (self.run)(ctx)
    }
}

/// A registry of the one `kind` and the `ty` it reads or writes.
pub fn registry_of(ty: &str, kind: Arc<dyn Node>) -> Registry {
    let mut reg = Registry::new();
    reg.add_type(ty, "files of the test's own kind");
    reg.add_node(kind).unwrap();
    reg
}

/// The body of a test binary's child process, started by [`spawn_child`]: runs the graph
/// named by its environment on one worker (where that names none, it is not a child:
/// nothing to do).
pub fn run_child_graph_from_env() {
    let (Ok(graph), Ok(cache)) = (std::env::var("CHILD_GRAPH"), std::env::var("CHILD_CACHE"))
    else {
        return;
    };
    let out = std::env::var("CHILD_OUT").ok();
    let r = run_graph(
        Path::new(&graph),
        Path::new(&cache),
        out.as_deref().map(Path::new),
        &[],
        1,
    );
    assert!(r.ok, "{}", r.render_table());
}

/// This test binary again, running only its ignored test `child_test` (whose body is
/// [`run_child_graph_from_env`]) on `graph` with the cache at `cache` and outputs in `out`.
pub fn spawn_child(
    child_test: &str,
    graph: &Path,
    cache: &Path,
    out: &Path,
    stderr: Stdio,
) -> Child {
    Command::new(std::env::current_exe().unwrap())
        .args(["--ignored", "--exact", child_test, "--nocapture"])
        .env("CHILD_GRAPH", graph)
        .env("CHILD_CACHE", cache)
        .env("CHILD_OUT", out)
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .unwrap()
}

/// The execution log: every node or item that actually ran, sorted.
pub fn ran(report: &RunReport) -> Vec<String> {
    let mut v = Vec::new();
    for n in &report.nodes {
        if n.items.is_empty() {
            if n.status == Status::Ran {
                v.push(n.id.clone());
            }
        } else {
            for i in &n.items {
                if i.status == Status::Ran {
                    v.push(format!("{}[{}]", n.id, i.name));
                }
            }
        }
    }
    v.sort();
    v
}

pub fn status(report: &RunReport, id: &str) -> Status {
    report
        .node(id)
        .unwrap_or_else(|| panic!("no node {id} in report"))
        .status
}

/// Why node `id` failed or was skipped, if the report says.
pub fn reason<'a>(report: &'a RunReport, id: &str) -> Option<&'a str> {
    report
        .node(id)
        .unwrap_or_else(|| panic!("no node {id} in report"))
        .reason
        .as_deref()
}
