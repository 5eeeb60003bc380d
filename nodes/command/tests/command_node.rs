//! The `command` node with real programs (python3 -c ..., sh -c ...): declared ports, placeholders,
//! inputs as private copies, outputs collected from folders; a failure, a timeout and a
//! missing or empty output each fail with a message naming the cause and quoting stderr;
//! a bad declaration is refused before anything runs, naming the param.

use objectsplat_command::node::CommandNode;
use objectsplat_runtime::testing::run_node;
use objectsplat_runtime::{Node, Params, Value};
use std::path::Path;
use std::time::Instant;

/// A RON string literal for `text`.
fn ron(text: &str) -> String {
    format!("{text:?}")
}

fn argv(args: &[&str]) -> String {
    format!(
        "[{}]",
        args.iter().map(|a| ron(a)).collect::<Vec<_>>().join(", ")
    )
}

/// Params for a program without inputs that writes the `produces` ports (RON map text).
fn producing(produces: &str, args: &[&str]) -> String {
    format!("(argv: {}, produces: {produces})", argv(args))
}

/// The full error chain of a run without inputs that must fail.
fn failure(dir: &Path, params: &str) -> String {
    let e = run_node(&CommandNode, &[], params, dir, None)
        .err()
        .unwrap();
    format!("{e:#}")
}

/// Asserts that the message `e` contains every one of `parts`.
fn assert_mentions(e: &str, parts: &[&str]) {
    assert!(parts.iter().all(|part| e.contains(part)), "{e}");
}

fn input(dir: &Path, text: &str) -> std::path::PathBuf {
    let d = dir.join("input");
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("value.txt"), text).unwrap();
    d
}

const COPY_AND_SCALE: &str = "import json, os, sys; src, dst, opts = sys.argv[1:4]; \
    o = json.load(open(opts)); v = int(open(os.path.join(src, 'value.txt')).read()); \
    open(os.path.join(src, 'value.txt'), 'w').write('spoiled'); \
    open(os.path.join(dst, 'value.txt'), 'w').write(str(v * o['factor'])); \
    print('scaled by', sys.argv[4], file=sys.stderr)";

#[test]
fn declared_ports_placeholders_and_options_reach_the_program() {
    let dir = tempfile::tempdir().unwrap();
    let inp = input(dir.path(), "21");
    let params = format!(
        "(argv: {}, consumes: {{\"number\": \"File\"}}, produces: {{\"scaled\": \"File\"}}, options: {{\"factor\": 2}})",
        argv(&[
            "python3",
            "-c",
            COPY_AND_SCALE,
            "{in:number}",
            "{out:scaled}",
            "{options}",
            "x{opt:factor}"
        ])
    );
    let out = dir.path().join("out");
    let run = run_node(&CommandNode, &[("number", &inp)], &params, &out, None).unwrap();
    assert_eq!(
        std::fs::read_to_string(run.outputs["scaled"].join("value.txt")).unwrap(),
        "42"
    );
    // The program wrote into its own copy of the input, not into the input.
    assert_eq!(
        std::fs::read_to_string(inp.join("value.txt")).unwrap(),
        "21"
    );
    assert!(
        run.notes
            .iter()
            .any(|(k, v)| k == "stderr (last line)" && v == "scaled by x2"),
        "{:?}",
        run.notes
    );
}

#[test]
fn a_failing_program_fails_the_node_with_its_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let script = "import sys; print('CUDA out of memory', file=sys.stderr); sys.exit(3)";
    let params = producing("{\"out\": \"File\"}", &["python3", "-c", script]);
    let e = failure(dir.path(), &params);
    assert_mentions(
        &e,
        &[
            "command \"python3\" failed (exit status: 3)",
            "CUDA out of memory",
        ],
    );
    let params = producing("{\"out\": \"File\"}", &["no-such-program-anywhere"]);
    let e = failure(dir.path(), &params);
    assert_mentions(&e, &["cannot start command \"no-such-program-anywhere\""]);
}

#[test]
fn a_program_past_its_timeout_is_killed() {
    let dir = tempfile::tempdir().unwrap();
    // sh starts in milliseconds even on a loaded machine, so the message is out before the timeout.
    let params = format!(
        "(argv: {}, produces: {{\"out\": \"File\"}}, timeout_s: 1.0)",
        argv(&["sh", "-c", "echo loading weights >&2; sleep 30"])
    );
    let t0 = Instant::now();
    let e = failure(dir.path(), &params);
    assert!(t0.elapsed().as_secs_f64() < 10.0);
    assert_mentions(
        &e,
        &[
            "command \"sh\" did not finish within 1.0 s and was killed",
            "loading weights",
        ],
    );
}

#[test]
fn outputs_must_be_written_in_their_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let params = producing("{\"masks\": \"File\"}", &["python3", "-c", "pass"]);
    let e = failure(dir.path(), &params);
    assert!(e.contains("wrote nothing into output `masks`"), "{e}");
    let script = "import sys; open(sys.argv[1] + '/cameras.json', 'w').write('[]')";
    let params = producing(
        "{\"frames\": \"Frames\"}",
        &["python3", "-c", script, "{out:frames}"],
    );
    let e = failure(dir.path(), &params);
    assert!(
        e.contains("wrote output `frames` (Frames) without frames.json"),
        "{e}"
    );
}

/// The error `declared_ports` gives for `params` (RON struct text, defaults filled in).
fn declaration_error(params: &str) -> String {
    let spec = CommandNode.spec();
    let given = objectsplat_runtime::syntax::parse(params)
        .unwrap()
        .to_value();
    let Value::Struct(_, given) = given else {
        panic!("params must be a struct")
    };
    let mut values = std::collections::BTreeMap::new();
    for ps in &spec.params {
        let v = match given.iter().find(|(k, _)| *k == ps.name) {
            Some((_, v)) => v.clone(),
            None => objectsplat_runtime::syntax::parse(ps.default.as_deref().unwrap())
                .unwrap()
                .to_value(),
        };
        values.insert(ps.name.clone(), ps.ty.check(&v).unwrap());
    }
    let e = CommandNode
        .declared_ports(&Params::new(values))
        .expect_err("the declaration is refused");
    format!("{}: {}", e.param, e.message)
}

#[test]
fn bad_declarations_are_refused_naming_the_param() {
    for (params, want) in [
        (
            "(argv: [], produces: {\"o\": \"File\"})",
            "argv: the command is empty",
        ),
        (
            "(argv: [\"p\", \"{in:frame}\"], consumes: {\"frames\": \"Frames\"}, produces: {\"o\": \"File\"})",
            "argv: {in:frame} names the input port `frame`, which is not declared; the inputs are frames",
        ),
        (
            "(argv: [\"p\", \"{script}\"], produces: {\"o\": \"File\"})",
            "argv: {script} is used but no `script` is given",
        ),
        (
            "(argv: [\"p\", \"--k={opt:k}\"], produces: {\"o\": \"File\"})",
            "argv: {opt:k} names the option `k`, which `options` does not give",
        ),
        (
            "(argv: [\"p\"], produces: {})",
            "produces: declare at least one output port",
        ),
        (
            "(argv: [\"p\"], produces: {\"my masks\": \"File\"})",
            "produces: port name \"my masks\" must be made of letters, digits and `_`",
        ),
        (
            "(argv: [\"p\"], produces: {\"o\": \"[File\"})",
            "produces: port `o`: `[File` is not a type",
        ),
        (
            "(argv: [\"p\"], consumes: {\"x\": \"File\"}, produces: {\"x\": \"File\"})",
            "produces: `x` is declared both as an input and as an output",
        ),
        ("(argv: [\"p\"], produces: [\"o\"])", "produces: "),
    ] {
        let e = declaration_error(params);
        assert!(e.starts_with(want), "{params}: {e}");
    }
}

#[test]
fn maps_of_the_wrong_shape_are_refused_with_the_shape_expected() {
    let e = declaration_error("(argv: [\"p\"], produces: [\"o\"])");
    assert!(e.starts_with("produces: parameter `produces`"), "{e}");
    assert!(
        e.ends_with("; expected a map of port name to type, e.g. {\"frames\": \"Frames\"}"),
        "{e}"
    );
    let e = declaration_error("(argv: [\"p\"], produces: {\"o\": \"File\"}, options: [1])");
    assert!(e.starts_with("options: parameter `options`"), "{e}");
    assert!(e.ends_with("; expected a map of names to values"), "{e}");
}

#[test]
fn braces_that_are_no_placeholder_reach_the_program_verbatim() {
    let dir = tempfile::tempdir().unwrap();
    let literal = "{\"json\": [1, 2]} {unknown} {";
    let params = producing(
        "{\"o\": \"File\"}",
        &[
            "python3",
            "-c",
            "import sys; open(sys.argv[2] + '/a.txt', 'w').write(sys.argv[1])",
            literal,
            "{out:o}",
        ],
    );
    let run = run_node(&CommandNode, &[], &params, dir.path(), None).unwrap();
    assert_eq!(
        std::fs::read_to_string(run.outputs["o"].join("a.txt")).unwrap(),
        literal
    );
}
