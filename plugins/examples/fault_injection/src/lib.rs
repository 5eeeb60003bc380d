//! A test fixture, not an example to copy: a plugin that misbehaves on request, so
//! the host's refusals and failure isolation can be tested against a real library.
//!
//! - node `faulty_stage` (image → image) with `mode`: `pass` copies the image;
//!   `error` and `panic` fail politely; `abort`, `segfault`, `stack_overflow` and
//!   `exit` end the process the library runs in; `hang` never returns; `no_output`
//!   returns `done` without writing; `huge_error` fails with a 50 MB message;
//! - node `faulty_item` (Component → File), for fan-out tests (the Slurm executor's):
//!   writes the item's name and `component.json`; `sleep_s` waits first, `fail_item`
//!   names an item that fails every time, and `log` (an absolute path) gets a line
//!   `start|done <item> job=<SLURM_JOB_ID> pid=<pid> ...` per attempt, the record of
//!   what ran where (never part of the output);
//! - `OBJECTSPLAT_FAULT_VARIANT` (read when the host loads the library) turns the
//!   whole library bad: `wrong_abi` (entry table claims ABI v999), `malformed_describe`
//!   (truncated JSON), `kind_collision` (declares the built-in `load_image`),
//!   `unknown_type` (a port of type `Picture`);
//! - feature `no_entry` builds it without the entry symbol.
//!
//! It builds its entry table by hand (what `export_plugin!` generates), which also
//! documents the ABI for authors who do not use the macro.

use objectsplat_plugin_sdk::abi::{
    ABI_VERSION, EntryV1, HostV1, OwnedBuf, SDK_BUILD, STATUS_OK, StaticStr,
};
use objectsplat_plugin_sdk::artifacts::COMPONENT_JSON;
use objectsplat_plugin_sdk::prelude::*;

/// Recurses until the stack runs out; `black_box` keeps the frames and their arrays.
#[allow(unconditional_recursion)]
fn exhaust_stack(depth: u64) -> u64 {
    let frame = std::hint::black_box([depth; 512]);
    exhaust_stack(depth + 1) + frame[7]
}

fn faulty_stage(req: &mut Request) -> Result<Outcome> {
    match req.param::<String>("mode")?.as_str() {
        "error" => bail!("injected failure: faulty_stage refused its input"),
        "panic" => panic!("injected panic in faulty_stage"),
        "abort" => {
            eprintln!("faulty_stage: aborting on purpose");
            std::process::abort()
        }
        // SAFETY: none: writing to an unmapped page is the fault being injected (a
        // non-null, aligned address, so debug builds fault rather than assert).
        "segfault" => unsafe {
            std::ptr::write_volatile(0x10 as *mut u64, 1);
            unreachable!("the write above faults")
        },
        "stack_overflow" => Ok(if exhaust_stack(0) == 0 {
            Outcome::Done
        } else {
            Outcome::Skipped("unreachable: the recursion never returns".into())
        }),
        "exit" => std::process::exit(0),
        "hang" => loop {
            std::thread::sleep(std::time::Duration::from_secs(1));
        },
        "no_output" => Ok(Outcome::Done),
        "huge_error" => bail!("injected huge error: {}", "x".repeat(50 << 20)),
        _ => {
            let image = read_image(req.input("image")?)?;
            write_image(&req.output("image")?, &image, 8)?;
            Ok(Outcome::Done)
        }
    }
}

/// Appends one line to the `log` param's file (nothing when it is empty).
fn log_line(req: &Request, event: &str) -> Result<()> {
    let path: String = req.param("log")?;
    if path.is_empty() {
        return Ok(());
    }
    let env = |k: &str| std::env::var(k).unwrap_or_else(|_| "-".into());
    let line = format!(
        "{event} {} job={} pid={} ppid={} cpus={} partition={} name={}\n",
        req.item().unwrap_or("-"),
        match (
            std::env::var("SLURM_ARRAY_JOB_ID"),
            std::env::var("SLURM_ARRAY_TASK_ID")
        ) {
            (Ok(a), Ok(t)) => format!("{a}_{t}"),
            _ => env("SLURM_JOB_ID"),
        },
        std::process::id(),
        std::os::unix::process::parent_id(),
        env("SLURM_CPUS_PER_TASK"),
        env("SLURM_JOB_PARTITION"),
        env("SLURM_JOB_NAME"),
    );
    use std::io::Write;
    // One write of a short line to a file opened for appending: lines of concurrent
    // writers do not interleave.
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .and_then(|mut f| f.write_all(line.as_bytes()))
        .map_err(|e| anyhow!("{path}: cannot append: {e}"))
}

fn faulty_item(req: &mut Request) -> Result<Outcome> {
    let item = req.item().unwrap_or("").to_string();
    log_line(req, "start")?;
    let sleep_s: f64 = req.param("sleep_s")?;
    let until = std::time::Instant::now() + std::time::Duration::from_secs_f64(sleep_s.max(0.0));
    while std::time::Instant::now() < until && !req.cancelled() {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    if req.param::<String>("fail_item")? == item {
        bail!("injected failure: faulty_item refused item {item}");
    }
    let info = std::fs::read(req.input("component")?.join(COMPONENT_JSON))
        .map_err(|e| anyhow!("component.json: {e}"))?;
    let out = req.output("file")?;
    let mut text = format!("{item}\n").into_bytes();
    text.extend_from_slice(&info);
    std::fs::write(out.join("item.txt"), text).map_err(|e| anyhow!("item.txt: {e}"))?;
    log_line(req, "done")?;
    Ok(Outcome::Done)
}

fn variant() -> String {
    std::env::var("OBJECTSPLAT_FAULT_VARIANT").unwrap_or_default()
}

fn plugin() -> &'static Plugin {
    static PLUGIN: std::sync::OnceLock<Plugin> = std::sync::OnceLock::new();
    PLUGIN.get_or_init(|| {
        let (kind, port_type) = match variant().as_str() {
            "kind_collision" => ("load_image", "Image"),
            "unknown_type" => ("faulty_stage", "Picture"),
            _ => ("faulty_stage", "Image"),
        };
        Plugin::new("fault_injection", "1")
            .node(
                NodeDecl::new("faulty_item", faulty_item)
                    .doc("Writes a component's name and info; sleeps, fails or logs on request.")
                    .input("component", "Component", "one item of a fan-out")
                    .output("file", "File", "item.txt: the item's name, then its component.json")
                    .param("sleep_s", "float", Some("0.0"), "seconds to wait first")
                    .param("fail_item", "string", Some("\"\""), "the item that fails")
                    .param("log", "string", Some("\"\""), "absolute path of the attempt log"),
            )
            .node(
            NodeDecl::new(kind, faulty_stage)
                .doc("Copies an image, or fails on purpose in the way `mode` names.")
                .input("image", port_type, "any image")
                .output("image", "Image", "the same pixels, 8-bit")
                .param(
                    "mode",
                    "enum(pass|error|panic|abort|segfault|stack_overflow|exit|hang|no_output|huge_error)",
                    Some("\"pass\""),
                    "how to behave",
                ),
        )
    })
}

unsafe extern "C" fn describe(out: *mut OwnedBuf) -> i32 {
    if variant() == "malformed_describe" && !out.is_null() {
        // SAFETY: the host passes a writable slot.
        unsafe {
            out.write(OwnedBuf::from_vec(
                br#"{"plugin": "fault_injection", "nodes": ["#.to_vec(),
            ))
        };
        return STATUS_OK;
    }
    // SAFETY: forwarded from the host, which upholds the contract.
    unsafe { objectsplat_plugin_sdk::export::describe(plugin, out) }
}

unsafe extern "C" fn run(
    request: *const u8,
    len: usize,
    host: *const HostV1,
    out: *mut OwnedBuf,
) -> i32 {
    // SAFETY: forwarded from the host, which upholds the contract.
    unsafe { objectsplat_plugin_sdk::export::run(plugin, request, len, host, out) }
}

const fn table(abi_version: u32) -> EntryV1 {
    EntryV1 {
        abi_version,
        struct_size: std::mem::size_of::<EntryV1>(),
        plugin_build: StaticStr::new(concat!(
            env!("CARGO_PKG_NAME"),
            " ",
            env!("CARGO_PKG_VERSION")
        )),
        sdk_build: StaticStr::new(SDK_BUILD),
        describe,
        run,
        free: objectsplat_plugin_sdk::export::free,
    }
}

static ENTRY: EntryV1 = table(ABI_VERSION);
static FUTURE_ENTRY: EntryV1 = table(999);

/// The entry point, unless built with `no_entry`.
#[cfg(not(feature = "no_entry"))]
#[unsafe(no_mangle)]
pub extern "C" fn objectsplat_plugin_entry_v1() -> *const EntryV1 {
    // Reading the environment cannot panic (a missing or non-UTF-8 value is an Err).
    if variant() == "wrong_abi" {
        &FUTURE_ENTRY
    } else {
        &ENTRY
    }
}

/// Keeps the tables referenced when the entry symbol is compiled out.
#[cfg(feature = "no_entry")]
pub fn tables() -> [&'static EntryV1; 2] {
    [&ENTRY, &FUTURE_ENTRY]
}
