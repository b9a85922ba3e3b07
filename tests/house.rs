//! The house rules that a reader of the tree relies on (issue 17), checked
//! on the sources themselves:
//!
//! - no Rust or WGSL file over 600 lines — sources, tests, benches,
//!   examples and shaders — except the exemptions stated in [`EXEMPT`];
//! - no import cycle between the files of a crate;
//! - every XPBD kernel's three faces share its name: `cpu/src/K.rs` (the
//!   golden path), `shaders/K.wgsl` (the kernel) and its dispatch at the
//!   exact path [`XPBD_KERNELS`] names (`gpu/src/xpbd/K.rs`, collide's
//!   `gpu/src/collide.rs`), not any file of that name.
//!
//! A file's imports are the `crate::…` and `super::…` paths in its code
//! (comments and its `#[cfg(test)] mod tests` left out), each resolved to
//! the file that defines the named item, following `pub use` re-exports.
//! A path to a module's own ancestor or descendant is the module tree, not
//! an import, and is left out.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

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
const EXEMPT: &[(&str, &str)] = &[(
    "shaders/coupled.wgsl",
    "the coupled step's passes; being reshaped with the GPU backends (issue 33, item 3)",
)];

/// Lines a non-test source file may have.
const MAX_LINES: usize = 600;

type Module = Vec<String>;

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable source dir") {
        let path = entry.expect("dir entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `a/b.rs` → [a, b]; `a/mod.rs` → [a]; `lib.rs`, `main.rs` → [].
fn module_of(root: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(root).expect("file under its root");
    let mut parts: Module = rel
        .with_extension("")
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("lib" | "main" | "mod")
    ) {
        parts.pop();
    }
    parts
}

/// The file's code: comments and the unit-test module dropped.
fn code_of(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Every path starting at `keyword` (`crate` or `super`) in `code`, with
/// `{a, b::c}` groups expanded one level: [keyword, seg, …].
fn paths_from(code: &str, keyword: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes: Vec<char> = code.chars().collect();
    let key: Vec<char> = keyword.chars().collect();
    let mut i = 0;
    while i + key.len() <= bytes.len() {
        let starts = bytes[i..i + key.len()] == key[..]
            && (i == 0 || !is_ident(bytes[i - 1]))
            && bytes.get(i + key.len()) == Some(&':');
        if !starts {
            i += 1;
            continue;
        }
        let mut j = i + key.len();
        let mut path = vec![keyword.to_string()];
        loop {
            if bytes.get(j) == Some(&':') && bytes.get(j + 1) == Some(&':') {
                j += 2;
            } else {
                break;
            }
            if bytes.get(j) == Some(&'{') {
                let end = bytes[j..]
                    .iter()
                    .position(|&c| c == '}')
                    .map_or(bytes.len(), |e| j + e);
                let group: String = bytes[j + 1..end].iter().collect();
                for item in group.split(',') {
                    // `a::b::C` (or `a::b::C as D`): every segment of the item.
                    let item = item.trim().split(" as ").next().unwrap_or("");
                    let segments: Vec<String> = item
                        .split("::")
                        .map(|s| s.trim().chars().take_while(|&c| is_ident(c)).collect())
                        .take_while(|s: &String| !s.is_empty())
                        .collect();
                    if !segments.is_empty() {
                        let mut p = path.clone();
                        p.extend(segments);
                        out.push(p);
                    }
                }
                path.clear();
                j = end;
                break;
            }
            let segment: String = bytes[j..].iter().take_while(|&&c| is_ident(c)).collect();
            if segment.is_empty() {
                break;
            }
            j += segment.chars().count();
            path.push(segment);
        }
        if path.len() > 1 {
            out.push(path);
        }
        i = j.max(i + 1);
    }
    out
}

/// One crate's files and what each imports.
struct Crate {
    files: BTreeMap<Module, PathBuf>,
    /// (module, name) → the module `pub use` took the name from.
    reexports: BTreeMap<(Module, String), Module>,
    code: BTreeMap<Module, String>,
}

impl Crate {
    fn read(root: &Path) -> Crate {
        let mut paths = Vec::new();
        rust_files(root, &mut paths);
        let mut crate_ = Crate {
            files: BTreeMap::new(),
            reexports: BTreeMap::new(),
            code: BTreeMap::new(),
        };
        for path in paths {
            let module = module_of(root, &path);
            let text = std::fs::read_to_string(&path).expect("readable source");
            crate_.code.insert(module.clone(), code_of(&text));
            crate_.files.insert(module, path);
        }
        for (module, code) in &crate_.code {
            for statement in code.split(';') {
                let statement: String = statement.split_whitespace().collect::<Vec<_>>().join(" ");
                // The re-export this piece ends with, if any.
                let Some(start) = statement
                    .rfind("pub use ")
                    .or_else(|| statement.rfind("pub(crate) use "))
                else {
                    continue;
                };
                let rest = statement[start..]
                    .split_once(" use ")
                    .map_or("", |(_, r)| r);
                let Some((prefix, names)) =
                    rest.split_once("::{").or_else(|| rest.rsplit_once("::"))
                else {
                    continue;
                };
                let mut from: Module = match prefix.split("::").next() {
                    Some("crate") => Vec::new(),
                    Some("self") => module.clone(),
                    Some(first) if crate_.files.contains_key(&child(module, first)) => {
                        module.clone()
                    }
                    _ => continue,
                };
                from.extend(
                    prefix
                        .split("::")
                        .filter(|s| !matches!(*s, "crate" | "self"))
                        .map(str::to_string),
                );
                for item in names.trim_matches(|c| c == '{' || c == '}').split(',') {
                    // `a::B` inside a group re-exports B from `prefix::a`.
                    let (path, alias) = match item.split_once(" as ") {
                        Some((path, alias)) => (path, Some(alias)),
                        None => (item, None),
                    };
                    let mut segments: Vec<&str> = path.trim().split("::").collect();
                    let last = segments.pop().unwrap_or("");
                    let name = alias.unwrap_or(last);
                    if !name.is_empty() {
                        let mut source = from.clone();
                        source.extend(segments.iter().map(|s| s.trim().to_string()));
                        crate_
                            .reexports
                            .insert((module.clone(), name.trim().to_string()), source);
                    }
                }
            }
        }
        crate_
    }

    /// The file a path names: its longest prefix that is a file, after
    /// following re-exports of the item it names.
    fn resolve(&self, mut full: Module) -> Option<Module> {
        for _ in 0..4 {
            let Some((last, parent)) = full.split_last() else {
                break;
            };
            match self.reexports.get(&(parent.to_vec(), last.clone())) {
                Some(from) => {
                    let mut next = from.clone();
                    next.push(last.clone());
                    full = next;
                }
                None => break,
            }
        }
        (1..=full.len())
            .rev()
            .map(|k| full[..k].to_vec())
            .find(|m| self.files.contains_key(m))
    }

    /// The files `module` imports (not its ancestors or descendants).
    fn imports(&self, module: &Module) -> BTreeSet<Module> {
        let code = &self.code[module];
        let mut out = BTreeSet::new();
        for keyword in ["crate", "super"] {
            for path in paths_from(code, keyword) {
                let mut full: Module = if keyword == "crate" {
                    Vec::new()
                } else {
                    module[..module.len().saturating_sub(1)].to_vec()
                };
                full.extend(path[1..].iter().cloned());
                if let Some(target) = self.resolve(full)
                    && !related(&target, module)
                {
                    out.insert(target);
                }
            }
        }
        out
    }
}

fn child(module: &Module, name: &str) -> Module {
    let mut m = module.clone();
    m.push(name.to_string());
    m
}

/// One is an ancestor of (or equal to) the other.
fn related(a: &Module, b: &Module) -> bool {
    let n = a.len().min(b.len());
    a[..n] == b[..n]
}

/// The strongly connected components of more than one file (Tarjan).
fn cycles(graph: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct Search<'a> {
        graph: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<Module, usize>,
        low: BTreeMap<Module, usize>,
        stack: Vec<Module>,
        on_stack: BTreeSet<Module>,
        found: Vec<Vec<Module>>,
    }
    fn visit(s: &mut Search<'_>, v: &Module) {
        let n = s.index.len();
        s.index.insert(v.clone(), n);
        s.low.insert(v.clone(), n);
        s.stack.push(v.clone());
        s.on_stack.insert(v.clone());
        for w in s.graph.get(v).into_iter().flatten() {
            if !s.index.contains_key(w) {
                visit(s, w);
                let low = s.low[v].min(s.low[w]);
                s.low.insert(v.clone(), low);
            } else if s.on_stack.contains(w) {
                let low = s.low[v].min(s.index[w]);
                s.low.insert(v.clone(), low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(&w);
                let done = &w == v;
                component.push(w);
                if done {
                    break;
                }
            }
            if component.len() > 1 {
                s.found.push(component);
            }
        }
    }
    let mut s = Search {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.found
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
        files.iter().any(|f| f.ends_with("tests/house.rs"))
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
