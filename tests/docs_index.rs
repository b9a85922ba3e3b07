//! The README's Layout and docs index stay true, and every relative link in
//! the README, the changelog and docs/ resolves.
//!
//! ```text
//! Layout (README "## Layout" up to "## Docs") names every workspace crate,
//!        every top-level folder, every bench and every test folder
//! Docs   (README "## Docs") names every docs/*.md
//! links  [text](path#anchor) in README.md, CHANGELOG.md, docs/*.md (outside
//!        code fences): path exists; an anchor into a .md file is one of its
//!        headings' GitHub slugs (lowercase, punctuation dropped, spaces → -,
//!        repeats numbered -1, -2, …) or an explicit id/name attribute
//! ```
//! No GPU and no build of the library needed: text only.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(path: &Path) -> String {
    fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The README text from `## start` up to the next `## ` heading in `ends`.
fn section(readme: &str, start: &str, end: Option<&str>) -> String {
    let from = readme
        .find(&format!("\n## {start}\n"))
        .unwrap_or_else(|| panic!("README has no \"## {start}\" section"));
    let rest = &readme[from + 1..];
    match end {
        Some(end) => {
            let to = rest
                .find(&format!("\n## {end}\n"))
                .unwrap_or_else(|| panic!("README has no \"## {end}\" after \"## {start}\""));
            rest[..to].to_string()
        }
        None => rest.to_string(),
    }
}

/// Names of the entries of `dir` that are folders (or, with `ext`, files
/// with that extension, stem only), hidden ones excluded.
fn entries(dir: &Path, ext: Option<&str>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for entry in fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.expect("readable folder entry").path();
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("")
            .to_string();
        if name.starts_with('.') {
            continue;
        }
        match ext {
            None if path.is_dir() => {
                out.insert(name);
            }
            Some(ext)
                if path.is_file() && path.extension().and_then(|e| e.to_str()) == Some(ext) =>
            {
                let stem = path
                    .file_stem()
                    .and_then(|s| s.to_str())
                    .unwrap_or("")
                    .to_string();
                out.insert(stem);
            }
            _ => {}
        }
    }
    out
}

fn workspace_members() -> Vec<String> {
    let manifest = read(&root().join("Cargo.toml"));
    let line = manifest
        .lines()
        .find(|l| l.trim_start().starts_with("members"))
        .expect("workspace members line");
    let list = &line[line.find('[').expect("[") + 1..line.find(']').expect("]")];
    list.split(',')
        .map(|m| m.trim().trim_matches('"').to_string())
        .filter(|m| !m.is_empty())
        .collect()
}

#[test]
fn layout_names_every_crate_folder_bench_and_test_folder() {
    let readme = read(&root().join("README.md"));
    let layout = section(&readme, "Layout", Some("Docs"));
    let mut missing = Vec::new();
    let members = workspace_members();
    assert!(members.len() >= 6, "workspace members parsed: {members:?}");
    for crate_dir in &members {
        if !layout.contains(&format!("\n{crate_dir}/")) {
            missing.push(format!("crate {crate_dir}/"));
        }
    }
    let top = entries(&root(), None);
    assert!(
        top.contains("tests") && top.contains("docs"),
        "top folders: {top:?}"
    );
    for dir in top.iter().filter(|d| *d != "target") {
        if !layout.contains(&format!("\n{dir}/")) {
            missing.push(format!("top-level folder {dir}/"));
        }
    }
    let benches = root().join("benches");
    for bench in entries(&benches, Some("rs")) {
        if !layout.contains(&format!("`{bench}`")) {
            missing.push(format!("bench benches/{bench}.rs"));
        }
    }
    for dir in entries(&benches, None) {
        if !layout.contains(&format!("`{dir}/`")) {
            missing.push(format!("bench folder benches/{dir}/"));
        }
    }
    for dir in entries(&root().join("tests"), None) {
        if !layout.contains(&format!("`{dir}/`")) {
            missing.push(format!("test folder tests/{dir}/"));
        }
    }
    for file in ["Cargo.toml", "CHANGELOG.md"] {
        if !layout.contains(&format!("\n{file}")) {
            missing.push(format!("file {file}"));
        }
    }
    assert!(
        missing.is_empty(),
        "README ## Layout does not name: {missing:?} (add a line for each)"
    );
}

#[test]
fn docs_index_names_every_docs_page() {
    let readme = read(&root().join("README.md"));
    let index = section(&readme, "Docs", None);
    let pages = entries(&root().join("docs"), Some("md"));
    assert!(pages.len() >= 15, "docs pages found: {pages:?}");
    let missing: Vec<_> = pages
        .iter()
        .filter(|page| !index.contains(&format!("docs/{page}.md")))
        .collect();
    assert!(
        missing.is_empty(),
        "README ## Docs does not list docs/{{{missing:?}}}.md"
    );
}

/// The GitHub slug of a heading's text.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            '-' | '_' => Some(c),
            c if c.is_alphanumeric() => Some(c),
            _ => None,
        })
        .collect()
}

/// Lines outside ``` fences.
fn prose(text: &str) -> Vec<&str> {
    let mut inside = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            inside = !inside;
            continue;
        }
        if !inside {
            out.push(line);
        }
    }
    out
}

/// Every anchor a link may name in a markdown file.
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen: BTreeSet<String> = BTreeSet::new();
    let mut out = BTreeSet::new();
    for line in prose(text) {
        if let Some(title) = line.strip_prefix('#') {
            let base = slug(title.trim_start_matches('#'));
            let mut name = base.clone();
            let mut k = 0;
            while seen.contains(&name) {
                k += 1;
                name = format!("{base}-{k}");
            }
            seen.insert(name.clone());
            out.insert(name);
        }
        for attr in ["id=\"", "name=\""] {
            let mut rest = line;
            while let Some(at) = rest.find(attr) {
                let after = &rest[at + attr.len()..];
                if let Some(end) = after.find('"') {
                    out.insert(after[..end].to_string());
                }
                rest = after;
            }
        }
    }
    out
}

/// The targets of `[text](target)` and `![alt](target)` links in `line`.
fn link_targets(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let Some(end) = after.find(')') else { break };
        out.push(after[..end].trim().to_string());
        rest = &after[end..];
    }
    out
}

#[test]
fn every_relative_link_resolves() {
    let mut files = vec![root().join("README.md"), root().join("CHANGELOG.md")];
    files.extend(
        entries(&root().join("docs"), Some("md"))
            .into_iter()
            .map(|p| root().join("docs").join(format!("{p}.md"))),
    );
    let mut broken = Vec::new();
    let mut checked = 0;
    for file in &files {
        let text = read(file);
        let dir = file.parent().expect("file in a folder");
        for (n, line) in prose(&text).into_iter().enumerate() {
            for target in link_targets(line) {
                if target.starts_with("http://")
                    || target.starts_with("https://")
                    || target.starts_with("mailto:")
                {
                    continue;
                }
                checked += 1;
                let (path, anchor) = match target.split_once('#') {
                    Some((p, a)) => (p, Some(a)),
                    None => (target.as_str(), None),
                };
                let resolved = if path.is_empty() {
                    file.clone()
                } else {
                    dir.join(path)
                };
                let name = file
                    .strip_prefix(root())
                    .unwrap_or(file)
                    .display()
                    .to_string();
                if !resolved.exists() {
                    broken.push(format!(
                        "{name} (prose line {}): {target} (no such path)",
                        n + 1
                    ));
                    continue;
                }
                if let Some(anchor) = anchor
                    && resolved.extension().and_then(|e| e.to_str()) == Some("md")
                    && !anchors(&read(&resolved)).contains(anchor)
                {
                    broken.push(format!(
                        "{name} (prose line {}): {target} (no such heading)",
                        n + 1
                    ));
                }
            }
        }
    }
    assert!(
        checked > 50,
        "only {checked} links found: the parser is broken"
    );
    assert!(
        broken.is_empty(),
        "{} broken links:\n{}",
        broken.len(),
        broken.join("\n")
    );
}

#[test]
fn the_slug_rule_matches_github() {
    assert_eq!(slug(" Whole-step table"), "whole-step-table");
    assert_eq!(
        slug("Barrier path (incremental potential)"),
        "barrier-path-incremental-potential"
    );
    assert_eq!(
        slug("Whole steps: one frame at a time (`tests/gpu_differential.rs`, `hyperpbd compare`)"),
        "whole-steps-one-frame-at-a-time-testsgpu_differentialrs-hyperpbd-compare"
    );
    let text = "# A\n## A\n```\n# not a heading\n```\n<a id=\"x\"></a>\n";
    let found = anchors(text);
    assert!(found.contains("a") && found.contains("a-1") && found.contains("x"));
    assert!(!found.contains("not-a-heading"));
}
