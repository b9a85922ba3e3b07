//! No submodule adds an `impl` to a type its parent file declares: a
//! type lives in one file, and a part of it is a type of its own (issue
//! 33). A file `a/b.rs` (or `a/b/mod.rs`) is checked against `a.rs` (or
//! `a/mod.rs`): every `impl<…> X<…>` and `impl<…> Trait for X<…>` in the
//! child whose `X` the parent declares (`struct`, `enum`, `union`,
//! `type`) is flagged.

use std::collections::BTreeSet;

use super::sources::{Crate, Module, is_ident};
use super::{ROOTS, workspace};

/// Parents whose type (folder of the crate root, type name) its
/// submodules may still add `impl`s to, each with the reason. An entry
/// the check no longer needs must leave (checked).
const SPREAD: &[(&str, &str, &str)] = &[
    (
        "core/src/builders",
        "SceneBuilder",
        "the builder's public methods, one scene family per file",
    ),
    (
        "cpu/src/coupled/elements",
        "Elements",
        "the coupled elements' material and contact-gradient passes",
    ),
    (
        "verify/src/compare_frame",
        "FrameErrorModel",
        "the per-particle comparison of the frame error model",
    ),
];

/// The names of the types (`struct`, `enum`, `union`, `type`, `trait`
/// objects aside) `code` declares.
fn declared_types(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in code.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        for (k, w) in words.iter().enumerate() {
            if matches!(*w, "struct" | "enum" | "union" | "type")
                && let Some(name) = words.get(k + 1)
            {
                let name: String = name.chars().take_while(|&c| is_ident(c)).collect();
                if !name.is_empty() {
                    out.insert(name);
                }
                break;
            }
        }
    }
    out
}

/// The type each `impl` item of `code` is for: `impl<…> X<…>` and
/// `impl<…> Trait for X<…>` give `X` (the last segment of its path).
fn impl_targets(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in code.lines().map(str::trim_start) {
        let Some(rest) = line.strip_prefix("impl") else {
            continue;
        };
        let mut rest = rest.trim_start();
        if rest.starts_with('<') {
            let mut depth = 0;
            let end = rest.char_indices().find_map(|(i, c)| {
                depth += match c {
                    '<' => 1,
                    '>' => -1,
                    _ => 0,
                };
                (depth == 0).then_some(i + 1)
            });
            rest = &rest[end.unwrap_or(rest.len())..];
        } else if !line.starts_with("impl ") {
            continue;
        }
        let head = rest.split(['{', '\n']).next().unwrap_or("");
        let head = head.split(" where").next().unwrap_or("");
        let target = head.rsplit_once(" for ").map_or(head, |(_, t)| t).trim();
        let target = target.split('<').next().unwrap_or("");
        let name = target.rsplit("::").next().unwrap_or("").trim();
        if !name.is_empty() {
            out.push(name.to_string());
        }
    }
    out
}

/// `(parent file, type, child file)` for every `impl` a child module of
/// `crate_` adds to a type its parent declares.
fn spread_impls(crate_: &Crate) -> Vec<(Module, String, Module)> {
    let mut found = Vec::new();
    for (module, code) in &crate_.code {
        let Some((_, parent)) = module.split_last() else {
            continue;
        };
        let Some(parent_code) = crate_.code.get(parent) else {
            continue;
        };
        let types = declared_types(parent_code);
        for target in impl_targets(code) {
            if types.contains(&target) {
                found.push((parent.to_vec(), target, module.clone()));
            }
        }
    }
    found
}

#[test]
fn no_submodule_adds_an_impl_to_its_parents_type() {
    let (mut found, mut used) = (Vec::new(), BTreeSet::new());
    for root in ROOTS {
        let crate_ = Crate::read(&workspace().join(root));
        for (parent, name, module) in spread_impls(&crate_) {
            let folder = [*root]
                .into_iter()
                .chain(parent.iter().map(String::as_str))
                .collect::<Vec<_>>()
                .join("/");
            match SPREAD
                .iter()
                .position(|(f, t, _)| *f == folder && *t == name)
            {
                Some(k) => {
                    used.insert(k);
                }
                None => found.push(format!("{root}/{}: impl {name}", module.join("/"))),
            }
        }
    }
    let stale: Vec<_> = (0..SPREAD.len()).filter(|k| !used.contains(k)).collect();
    assert!(
        found.is_empty(),
        "a submodule adds an impl to its parent's type (make the part a type of its own): \
         {found:?}"
    );
    assert!(
        stale.is_empty(),
        "SPREAD entries no longer needed: {stale:?}"
    );
}

/// The spread check sees a child's `impl` of its parent's type, plain,
/// generic and of a trait, and nothing else.
#[test]
fn the_spread_check_finds_a_planted_impl() {
    let dir = std::env::temp_dir().join(format!("hyperpbd-spread-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("a")).unwrap();
    std::fs::write(dir.join("lib.rs"), "mod a;\npub struct Top;\n").unwrap();
    std::fs::write(
        dir.join("a.rs"),
        "mod b;\nmod c;\npub struct Whole<S> { s: S }\npub(crate) type Alias = Whole<u8>;\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("a/b.rs"),
        "impl<S: Clone> Whole<S> {}\nimpl std::fmt::Debug for super::Alias {}\nimpl Top {}\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("a/c.rs"),
        "pub struct Own;\nimpl Own {\n    fn f(x: impl Fn()) {}\n}\n",
    )
    .unwrap();
    let found = spread_impls(&Crate::read(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
    let names: Vec<String> = found
        .iter()
        .map(|(p, t, m)| format!("{}:{t}:{}", p.join("/"), m.join("/")))
        .collect();
    assert_eq!(names, ["a:Whole:a/b", "a:Alias:a/b"]);
}
