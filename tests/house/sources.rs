//! The crates' files read as a module tree: each file's code (comments
//! and its unit tests left out), the `crate::…` and `super::…` paths it
//! imports resolved to files through `pub use` re-exports, and the cycles
//! of that graph (Tarjan).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

pub type Module = Vec<String>;

pub fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
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
pub fn module_of(root: &Path, file: &Path) -> Module {
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
pub fn code_of(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

pub fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Every path starting at `keyword` (`crate` or `super`) in `code`, with
/// `{a, b::c}` groups expanded one level: [keyword, seg, …].
pub fn paths_from(code: &str, keyword: &str) -> Vec<Vec<String>> {
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
pub struct Crate {
    pub files: BTreeMap<Module, PathBuf>,
    /// (module, name) → the module `pub use` took the name from.
    reexports: BTreeMap<(Module, String), Module>,
    pub code: BTreeMap<Module, String>,
}

impl Crate {
    pub fn read(root: &Path) -> Crate {
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
    pub fn imports(&self, module: &Module) -> BTreeSet<Module> {
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

pub fn child(module: &Module, name: &str) -> Module {
    let mut m = module.clone();
    m.push(name.to_string());
    m
}

/// One is an ancestor of (or equal to) the other.
pub fn related(a: &Module, b: &Module) -> bool {
    let n = a.len().min(b.len());
    a[..n] == b[..n]
}

/// The strongly connected components of more than one file (Tarjan).
pub fn cycles(graph: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
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
