//! `Program::run_logged`: a program's stdout and stderr land in one log file in the order
//! it wrote them; success returns the log's tail, failure quotes it.

use objectsplat_command::process::Program;
use std::time::Duration;

fn program<'a>(script: &str, workdir: &'a std::path::Path) -> Program<'a> {
    Program {
        what: "test program",
        argv: ["sh", "-c", script].map(Into::into).to_vec(),
        workdir,
        timeout: Duration::from_secs(30),
        cancelled: &|| false,
    }
}

#[test]
fn both_streams_reach_the_log_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("run.log");
    let tail = program("echo one; echo two >&2; echo three", dir.path())
        .run_logged(&log)
        .unwrap();
    assert_eq!(tail, "one\ntwo\nthree");
    assert_eq!(std::fs::read_to_string(&log).unwrap(), "one\ntwo\nthree\n");

    let e = program(
        "echo progress; echo 'ERROR: it broke' >&2; exit 3",
        dir.path(),
    )
    .run_logged(&log)
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("failed (exit status: 3); its log:\nprogress\nERROR: it broke"),
        "{e}"
    );
}
