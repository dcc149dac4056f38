//! The module map has no import circle: no top-level module of `src/`
//! uses (by a `crate::` path, outside comments and tests) a module that
//! uses it back, directly or through others. The `cli` layer may use
//! anything; nothing may use it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Top-level module of a file under src/ (`src/batch/mu.rs` → `batch`).
fn top(rel: &Path) -> Option<String> {
    let first = rel.components().next()?.as_os_str().to_str()?;
    Some(first.trim_end_matches(".rs").to_string())
}

fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).expect("read src") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            walk(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Module → the top-level modules its code names by `crate::` paths.
fn dependencies() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&src, &mut files);
    let mut mods: BTreeSet<String> = BTreeSet::new();
    for f in &files {
        if let Some(t) = top(f.strip_prefix(&src).expect("under src")) {
            mods.insert(t);
        }
    }
    let mut deps: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let Some(me) = top(f.strip_prefix(&src).expect("under src")) else {
            continue;
        };
        if me == "lib" || me == "bin" {
            continue;
        }
        let text = std::fs::read_to_string(f).expect("read");
        let code = text.split("#[cfg(test)]").next().unwrap_or("");
        let entry = deps.entry(me.clone()).or_default();
        for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for (i, _) in line.match_indices("crate::") {
                let rest = &line[i + "crate::".len()..];
                let rest = rest.trim_start_matches('{');
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                let name = match name.as_str() {
                    "Error" | "Result" => "error".to_string(),
                    _ => name,
                };
                if name != me && mods.contains(&name) {
                    entry.insert(name);
                }
            }
        }
    }
    deps
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let deps = dependencies();
    assert!(deps.len() >= 10, "{deps:?}");
    // Every module reachable from `m`.
    let reach = |m: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<String> = deps.get(m).into_iter().flatten().cloned().collect();
        while let Some(n) = todo.pop() {
            if seen.insert(n.clone()) {
                todo.extend(deps.get(&n).into_iter().flatten().cloned());
            }
        }
        seen
    };
    let mut circles = Vec::new();
    for m in deps.keys() {
        if reach(m).contains(m) {
            circles.push(m.clone());
        }
    }
    assert!(
        circles.is_empty(),
        "modules on an import circle: {circles:?}; deps {deps:?}"
    );
    for (m, d) in &deps {
        assert!(!d.contains("cli") || m == "cli", "{m} uses the cli layer");
    }
    // The core depends on nothing above it.
    assert!(deps["model"].is_empty(), "model uses {:?}", deps["model"]);
    assert!(
        !deps["sim"].iter().any(|d| d != "model"),
        "sim uses {:?}",
        deps["sim"]
    );
}
