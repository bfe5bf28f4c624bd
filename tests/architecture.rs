//! The pipeline's shape, kept true (docs/architecture.md). The workspace's
//! crates already make the compiler refuse an import against the pipeline;
//! this test reads the `crate::` paths of every file, as cargo-deny reads a
//! dependency graph, for what the compiler cannot see:
//!
//! - within a crate with layers, top-level modules import only the modules
//!   below them ([`CRATES`]), so data flows one way;
//! - the modules of a crate import each other without a cycle;
//! - no function over 120 lines, no file over 800 lines;
//! - no build path (`CARGO_MANIFEST_DIR`) outside the tests.
//!
//! Comments and test modules (`#[cfg(test)] mod tests`) are not read.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The workspace's crates by folder, each with its top-level modules from
/// the bottom of the pipeline to the top: a module may import only modules
/// listed before it. A crate that is one stage lists none.
#[rustfmt::skip]
const CRATES: [(&str, &[&str]); 11] = [
    ("crates/physics", &[]),
    ("crates/plan", &["util", "image_io", "timings", "trace", "plan"]),
    ("crates/metrics", &[]),
    ("crates/acquisition", &[
        "error", "interrupt", "render", "capture", "inputs", "backend", "runner",
    ]),
    ("crates/analysis", &["calibrate", "analysis", "advise"]),
    ("crates/results", &["exit", "comparison", "outdir", "inputs", "analysis", "advise", "cases", "model"]),
    ("crates/core", &[]),
    ("crates/report", &[]),
    ("crates/signoff", &[]),
    ("crates/engine", &["shard", "store", "pipeline", "campaign", "bench"]),
    (".", &["cli"]),
];

const MAX_FN_LINES: usize = 120;
const MAX_FILE_LINES: usize = 800;

struct Source {
    /// Its crate's index in [`CRATES`].
    krate: usize,
    /// Module path within its crate, e.g. `charts::trace` (`lib` for lib.rs).
    module: Vec<String>,
    /// The file relative to the workspace root.
    path: PathBuf,
    /// Whole text.
    text: String,
    /// Text without test modules and comment lines.
    code: String,
}

fn sources() -> Vec<Source> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    for (krate, c) in CRATES.iter().enumerate() {
        let src = root.join(c.0).join("src");
        let mut stack = vec![src.clone()];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else if path.extension().is_some_and(|e| e == "rs") {
                    let text = std::fs::read_to_string(&path).unwrap();
                    let mut module: Vec<String> = (path.strip_prefix(&src).unwrap())
                        .with_extension("")
                        .iter()
                        .map(|p| p.to_string_lossy().into_owned())
                        .collect();
                    if module.last().is_some_and(|m| m == "mod") {
                        module.pop();
                    }
                    let path = path.strip_prefix(root).unwrap().to_path_buf();
                    let code = code_of(&text);
                    #[rustfmt::skip]
                    out.push(Source { krate, module, path, text, code });
                }
            }
        }
    }
    out.sort_by(|a, b| a.path.cmp(&b.path));
    out
}

/// `text` up to its test module, without comment lines.
fn code_of(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let t = line.trim_start();
        if t.starts_with("#[cfg(test)]") {
            let next = lines.peek().map_or("", |l| l.trim_start());
            if next.starts_with("mod tests") || next.starts_with("pub(crate) mod tests") {
                break;
            }
        }
        if !t.starts_with("//") {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Every path that follows `prefix` in `code`, as its `::` segments; a
/// group `prefix{a, b::c}` gives one path per member.
fn paths_after(code: &str, prefix: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find(prefix) {
        let before = rest[..i].chars().next_back();
        rest = &rest[i + prefix.len()..];
        if before.is_some_and(is_ident) {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for member in group[..end].split(',') {
                let segs = segments(member.trim());
                if !segs.is_empty() {
                    out.push(segs);
                }
            }
        } else {
            let segs = segments(rest);
            if !segs.is_empty() {
                out.push(segs);
            }
        }
    }
    out
}

/// The `a::b::c` identifiers at the start of `s`.
fn segments(s: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = s;
    loop {
        let end = rest.find(|c: char| !is_ident(c)).unwrap_or(rest.len());
        if end == 0 {
            break;
        }
        out.push(rest[..end].to_string());
        match rest[end..].strip_prefix("::") {
            Some(r) => rest = r,
            None => break,
        }
    }
    out
}

/// Top-level module -> the top-level modules of its crate it imports, for
/// the crates that have layers.
fn top_level_graph(sources: &[Source]) -> BTreeMap<(usize, String), BTreeSet<String>> {
    let mut graph: BTreeMap<(usize, String), BTreeSet<String>> = BTreeMap::new();
    for s in sources.iter().filter(|s| !CRATES[s.krate].1.is_empty()) {
        let top = &s.module[0];
        if top == "lib" || top == "main" {
            continue;
        }
        let entry = graph.entry((s.krate, top.clone())).or_default();
        for p in paths_after(&s.code, "crate::") {
            if p[0] != *top {
                entry.insert(p[0].clone());
            }
        }
    }
    graph
}

#[test]
fn modules_import_only_layers_below_them() {
    let graph = top_level_graph(&sources());
    let mut wrong = Vec::new();
    for ((k, module), imports) in &graph {
        let rank = |m: &str| CRATES[*k].1.iter().position(|l| *l == m);
        let Some(r) = rank(module) else {
            wrong.push(format!(
                "{module} is in no layer: add it to CRATES and docs/architecture.md"
            ));
            continue;
        };
        // A name that is no module of this crate is a crate below it.
        for i in imports {
            if rank(i).is_some_and(|ri| ri >= r) {
                wrong.push(format!("{module} -> {i}"));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the pipeline's direction (docs/architecture.md): {wrong:#?}"
    );
}

/// The submodule a path names inside `top`, resolved to a file's module.
fn resolve(modules: &BTreeSet<Vec<String>>, path: &[String]) -> Option<Vec<String>> {
    (1..=path.len())
        .rev()
        .map(|k| path[..k].to_vec())
        .find(|m| modules.contains(m))
}

#[test]
fn submodules_have_no_import_cycle() {
    let all = sources();
    for (k, (dir, _)) in CRATES.iter().enumerate() {
        let sources: Vec<&Source> = all.iter().filter(|s| s.krate == k).collect();
        if let Some(cycle) = import_cycle(&sources) {
            panic!("import cycle in {dir}: {}", cycle.join(" -> "));
        }
    }
}

/// A cycle of imports between the modules of one crate, if any.
fn import_cycle(sources: &[&Source]) -> Option<Vec<String>> {
    let modules: BTreeSet<Vec<String>> = sources.iter().map(|s| s.module.clone()).collect();
    let mut graph: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for s in sources {
        let mut targets = BTreeSet::new();
        // In a crate with layers, edges between top-level modules are the
        // layers' business; a crate without is one stage, all of it read.
        let layered = !CRATES[s.krate].1.is_empty();
        for p in paths_after(&s.code, "crate::") {
            if !layered || p[0] == s.module[0] {
                targets.extend(resolve(&modules, &p));
            }
        }
        let parent = &s.module[..s.module.len().saturating_sub(1)];
        for p in paths_after(&s.code, "super::") {
            let mut full = parent.to_vec();
            full.extend(p);
            targets.extend(resolve(&modules, &full));
        }
        // A module always reaches its own children and parent through
        // `mod` and `super`: only edges between siblings' subtrees count.
        targets.retain(|t| !t.starts_with(&s.module) && !s.module.starts_with(t));
        graph.insert(s.module.clone(), targets);
    }
    // Depth-first search for a back edge.
    fn visit(
        m: &Vec<String>,
        graph: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        state: &mut BTreeMap<Vec<String>, u8>,
        stack: &mut Vec<Vec<String>>,
    ) -> Option<Vec<String>> {
        state.insert(m.clone(), 1);
        stack.push(m.clone());
        for t in graph.get(m).into_iter().flatten() {
            match state.get(t) {
                Some(1) => {
                    let from = stack.iter().position(|s| s == t).unwrap_or(0);
                    let mut cycle: Vec<String> =
                        stack[from..].iter().map(|s| s.join("::")).collect();
                    cycle.push(t.join("::"));
                    return Some(cycle);
                }
                Some(_) => {}
                None => {
                    if let Some(c) = visit(t, graph, state, stack) {
                        return Some(c);
                    }
                }
            }
        }
        stack.pop();
        state.insert(m.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    (graph.keys()).find_map(|m| {
        if state.contains_key(m) {
            return None;
        }
        visit(m, &graph, &mut state, &mut Vec::new())
    })
}

/// (first line, length) of every function of `text` longer than `max`.
fn long_functions(text: &str, max: usize) -> Vec<(usize, usize, String)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        let t = t
            .strip_prefix("pub(crate) ")
            .or_else(|| t.strip_prefix("pub(super) "))
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        let t = t.strip_prefix("const ").unwrap_or(t);
        if !t.starts_with("fn ") || line.trim_end().ends_with(';') {
            continue;
        }
        let indent = line.len() - line.trim_start().len();
        let end = lines[i + 1..].iter().position(|l| {
            l.len() > indent
                && l.len() - l.trim_start().len() == indent
                && l.trim_start().starts_with('}')
        });
        if let Some(e) = end {
            let n = e + 2;
            if n > max {
                out.push((i + 1, n, t.chars().take(60).collect()));
            }
        }
    }
    out
}

#[test]
fn functions_and_files_stay_short() {
    let mut wrong = Vec::new();
    for s in sources() {
        let n = s.text.lines().count();
        if n > MAX_FILE_LINES {
            wrong.push(format!("{}: {n} lines", s.path.display()));
        }
        for (line, len, head) in long_functions(&s.text, MAX_FN_LINES) {
            wrong.push(format!("{}:{line}: {len} lines: {head}", s.path.display()));
        }
    }
    assert!(
        wrong.is_empty(),
        "files over {MAX_FILE_LINES} lines or functions over {MAX_FN_LINES}: {wrong:#?}"
    );
}

/// An installed or copied binary has no source tree: no code outside the
/// tests may name a path of the machine that built it.
#[test]
fn no_build_path_reaches_the_binary() {
    let reaching: Vec<String> = sources()
        .iter()
        .filter(|s| s.code.contains("CARGO_MANIFEST_DIR") || s.code.contains("file!()"))
        .map(|s| s.path.display().to_string())
        .collect();
    assert!(reaching.is_empty(), "build paths in {reaching:?}");
}

#[test]
fn the_reader_finds_imports_and_cycles() {
    // The checks above can fail: their reader sees plain, grouped and
    // nested paths, and skips comments and test modules.
    let code = code_of(
        "use crate::plan::Plan;\nuse crate::{model, report::html};\n// crate::cli\nfn f() { crate::runner::run(); }\n#[cfg(test)]\nmod tests {\n    use crate::cli;\n}\n",
    );
    let tops: Vec<String> = paths_after(&code, "crate::")
        .into_iter()
        .map(|p| p[0].clone())
        .collect();
    assert_eq!(tops, ["plan", "model", "report", "runner"]);
    let long = format!("fn long() {{\n{}}}\n", "    x();\n".repeat(130));
    assert_eq!(long_functions(&long, MAX_FN_LINES).len(), 1);
    assert!(long_functions("fn short() {\n    x();\n}\n", MAX_FN_LINES).is_empty());
}
