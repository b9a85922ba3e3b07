//! The house rules that a reader of the tree relies on (issue 17), checked
//! on the sources themselves:
//!
//! - no Rust or WGSL file over 600 lines — sources, tests, benches,
//!   examples and shaders — except the exemptions stated in [`EXEMPT`];
//! - no import cycle between the files of a crate;
//! - no submodule adds an `impl` to a type its parent file declares (one
//!   type, one file: a part is a type of its own; [`spread::SPREAD`] the stated
//!   exceptions);
//! - every XPBD kernel's three faces share its name: `cpu/src/K.rs` (the
//!   golden path), `shaders/K.wgsl` (the kernel) and its dispatch at the
//!   exact path [`XPBD_KERNELS`] names (`gpu/src/xpbd/K.rs`, collide's
//!   `gpu/src/collide.rs`), not any file of that name;
//! - every mutant of the mutation harness still applies: its snippet
//!   occurs exactly once in its file (`scripts/mutants.py --check`), so
//!   code that moves cannot silently drop a mutant from the kill set.
//!
//! A file's imports are the `crate::…` and `super::…` paths in its code
//! (comments and its `#[cfg(test)] mod tests` left out), each resolved to
//! the file that defines the named item, following `pub use` re-exports.
//! A path to a module's own ancestor or descendant is the module tree, not
//! an import, and is left out.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use sources::{Crate, Module, cycles};

mod sources;
mod spread;

/// The crates' source roots, relative to the workspace.
const ROOTS: &[&str] = &[
    "core/src",
    "cpu/src",
    "gpu/src",
    "render/src",
    "report/src",
    "src",
    "verify/src",
];

/// Folders whose Rust and WGSL files the line rule covers besides
/// [`ROOTS`] (tests included: a test file is read as often as a source).
const OTHER_CODE: &[&str] = &[
    "tests",
    "benches",
    "examples",
    "shaders",
    "report/tests",
    "report/benches",
    "fuzz/fuzz_targets",
];

/// Files allowed over [`MAX_LINES`], each with the reason. Empty it as
/// they are split; a file that shrinks under the limit must leave this list
/// (checked), so an exemption cannot outlive its reason.
const EXEMPT: &[(&str, &str)] = &[];

/// Lines a non-test source file may have.
const MAX_LINES: usize = 600;

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Rust and WGSL files under `dir`.
fn code_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries {
        let path = entry.expect("dir entry").path();
        if path.is_dir() {
            code_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs" || e == "wgsl") {
            out.push(path);
        }
    }
}

#[test]
fn no_code_file_over_600_lines() {
    let root = workspace();
    let mut files = Vec::new();
    for dir in ROOTS.iter().chain(OTHER_CODE) {
        code_files(&root.join(dir), &mut files);
    }
    assert!(
        files.iter().any(|f| f.ends_with("tests/house/main.rs"))
            && files.iter().any(|f| f.ends_with("shaders/prelude.wgsl")),
        "the line rule must see tests/ and shaders/"
    );
    let mut long = Vec::new();
    let mut stale = Vec::new();
    for file in files {
        let lines = std::fs::read_to_string(&file)
            .expect("readable")
            .lines()
            .count();
        let name = file
            .strip_prefix(&root)
            .unwrap_or(&file)
            .display()
            .to_string();
        let exempt = EXEMPT.iter().any(|(path, _)| *path == name);
        if lines > MAX_LINES && !exempt {
            long.push(format!("{name} ({lines} lines)"));
        }
        if exempt && lines <= MAX_LINES {
            stale.push(name);
        }
    }
    assert!(long.is_empty(), "over {MAX_LINES} lines: {long:?}");
    assert!(
        stale.is_empty(),
        "exempt but no longer over {MAX_LINES} lines (remove from EXEMPT): {stale:?}"
    );
}

#[test]
fn no_import_cycle_between_files() {
    let mut found = Vec::new();
    for root in ROOTS {
        let crate_ = Crate::read(&workspace().join(root));
        let graph: BTreeMap<Module, BTreeSet<Module>> = crate_
            .files
            .keys()
            .map(|m| (m.clone(), crate_.imports(m)))
            .collect();
        for component in cycles(&graph) {
            let names: Vec<String> = component.iter().map(|m| m.join("/")).collect();
            found.push(format!("{root}: {names:?}"));
        }
    }
    assert!(found.is_empty(), "files that import each other: {found:?}");
}

/// The kernels of the XPBD step (core's `Kernel`: predict, velocity and
/// damping are `integrate`; projections `project` and `material`; friction;
/// the residual; the guards; particle contact's `collide`), each with the
/// exact path of its dispatch.
const XPBD_KERNELS: &[(&str, &str)] = &[
    ("integrate", "gpu/src/xpbd/integrate.rs"),
    ("project", "gpu/src/xpbd/project.rs"),
    ("material", "gpu/src/xpbd/material.rs"),
    ("friction", "gpu/src/xpbd/friction.rs"),
    ("residual", "gpu/src/xpbd/residual.rs"),
    ("guard", "gpu/src/xpbd/guard.rs"),
    ("collide", "gpu/src/collide.rs"),
];

#[test]
fn every_xpbd_kernel_has_its_three_faces_under_one_name() {
    let root = workspace();
    let mut missing = Vec::new();
    for (kernel, dispatch) in XPBD_KERNELS {
        assert!(
            Path::new(dispatch)
                .file_stem()
                .is_some_and(|s| s == *kernel),
            "{dispatch}: the dispatch of {kernel} must carry its name"
        );
        for face in [
            format!("cpu/src/{kernel}.rs"),
            format!("shaders/{kernel}.wgsl"),
            dispatch.to_string(),
        ] {
            if !root.join(&face).is_file() {
                missing.push(face);
            }
        }
    }
    assert!(missing.is_empty(), "kernel faces missing: {missing:?}");
}

/// The mutation catalog (scripts/mutants.toml) names snippets, not lines:
/// a refactor that moves or rewrites one leaves its mutant unable to run.
/// The harness's own check refuses such an entry.
#[test]
fn every_mutant_snippet_occurs_exactly_once() {
    let out = std::process::Command::new("python3")
        .arg("scripts/mutants.py")
        .arg("--check")
        .current_dir(workspace())
        .output()
        .expect("python3 runs scripts/mutants.py --check");
    let text = String::from_utf8_lossy(&out.stdout);
    let refused: Vec<&str> = text.lines().filter(|l| l.contains("REFUSED")).collect();
    assert!(
        out.status.success() && refused.is_empty(),
        "mutants whose snippet no longer applies (retarget them in scripts/mutants.toml \
         and re-run them): {refused:#?}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The checker sees a cycle where there is one: two files importing each
/// other, directly and through a re-export.
#[test]
fn the_cycle_check_finds_a_planted_cycle() {
    let dir = std::env::temp_dir().join(format!("hyperpbd-house-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("inner")).unwrap();
    std::fs::write(
        dir.join("lib.rs"),
        "mod a;\nmod inner;\npub use a::Thing;\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("a.rs"),
        "use crate::{inner::Renamed, more};\npub struct Thing;\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("inner/mod.rs"),
        "pub mod b;\npub use b::Other as Renamed;\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("inner/b.rs"),
        "// crate::a::Thing in a comment is no import\nuse crate::Thing;\npub struct Other;\n",
    )
    .unwrap();
    let crate_ = Crate::read(&dir);
    let graph: BTreeMap<Module, BTreeSet<Module>> = crate_
        .files
        .keys()
        .map(|m| (m.clone(), crate_.imports(m)))
        .collect();
    let found = cycles(&graph);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(found.len(), 1, "{graph:?}");
    let mut names: Vec<String> = found[0].iter().map(|m| m.join("/")).collect();
    names.sort();
    assert_eq!(names, ["a", "inner/b"]);
}
