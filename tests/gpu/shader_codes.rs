//! The integer codes the host and the WGSL share (`gpu/src/codes.rs`):
//! written into every composed module's header from the Rust tables, kept
//! by hand in no shader file, and named by every `switch` over an op.

use hyperpbd_gpu::Precision;
use hyperpbd_gpu::codes;
use hyperpbd_gpu::shader::{ShaderFile, compose};

fn shader_files() -> Vec<(String, String)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");
    let mut files: Vec<(String, String)> = std::fs::read_dir(dir)
        .expect("shaders/")
        .map(|entry| entry.expect("entry").path())
        .filter(|path| path.extension().is_some_and(|e| e == "wgsl"))
        .map(|path| {
            let text = std::fs::read_to_string(&path).expect("readable shader");
            (path.display().to_string(), text)
        })
        .collect();
    files.sort();
    assert!(files.len() > 20, "found {} shader files", files.len());
    files
}

#[test]
fn every_module_header_declares_every_code_with_the_hosts_value() {
    for file in ShaderFile::ALL {
        for precision in [Precision::F32, Precision::F64] {
            let module = compose(file, 3, precision);
            let mut declared = 0;
            for table in codes::ALL {
                for (name, value) in table {
                    let line = format!("const {name}: u32 = {value}u;");
                    assert_eq!(
                        module.matches(&line).count(),
                        1,
                        "{file:?} {precision}: `{line}` once"
                    );
                    declared += 1;
                }
            }
            assert!(declared >= 40, "{declared} codes");
        }
    }
}

#[test]
fn no_shader_file_keeps_a_shared_code_by_hand() {
    for (path, text) in shader_files() {
        for table in codes::ALL {
            for (name, _) in table {
                assert!(
                    !text.contains(&format!("const {name}:")),
                    "{path} defines {name}: it comes from the generated header (gpu/src/codes.rs)"
                );
            }
        }
    }
}

/// The bodies of every `switch (op)` of `text`.
fn op_switches(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("switch (op)") {
        let body = &rest[at..];
        let open = body.find('{').expect("switch body");
        let mut depth = 0;
        let mut end = open;
        for (k, c) in body[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + k;
                        break;
                    }
                }
                _ => {}
            }
        }
        out.push(&body[open..=end]);
        rest = &body[end..];
    }
    out
}

#[test]
fn every_switch_over_an_op_names_every_op() {
    let mut switches = 0;
    for (path, text) in shader_files() {
        for body in op_switches(&text) {
            switches += 1;
            let labels: String = body
                .lines()
                .filter(|l| l.trim_start().starts_with("case") || l.contains("OP_"))
                .collect::<Vec<_>>()
                .join("\n");
            for (name, _) in codes::OPS {
                let named = labels
                    .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .any(|word| word == *name);
                assert!(named, "{path}: a `switch (op)` does not name {name}");
            }
        }
    }
    // world_reals and run_op (step.wgsl), project_elements (project.wgsl).
    assert!(switches >= 3, "{switches} switches over an op");
}

#[test]
fn the_op_switch_finder_sees_a_missing_op() {
    let text = "fn f(op: u32) { switch (op) { case OP_PREDICT: { g(); } default: {} } }";
    let bodies = op_switches(text);
    assert_eq!(bodies.len(), 1);
    assert!(bodies[0].contains("OP_PREDICT") && !bodies[0].contains("OP_VELOCITY"));
}
