//! The diagnosis reads in one direction: no module of `src/diagnose/` reaches, through
//! `super::` paths, a module that reaches it back (no import circles).

use std::collections::{BTreeMap, BTreeSet};

/// `super::NAME` references outside the tests of each module file.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/diagnose");
    let files: Vec<(String, String)> = std::fs::read_dir(&dir)
        .expect("diagnose sources")
        .filter_map(|e| {
            let path = e.ok()?.path();
            let name = path.file_stem()?.to_str()?.to_string();
            (path.extension()? == "rs" && name != "mod").then(|| {
                let text = std::fs::read_to_string(&path).expect("readable");
                let code = text.split("#[cfg(test)]").next().unwrap_or("").to_string();
                (name, code)
            })
        })
        .collect();
    let names: BTreeSet<String> = files.iter().map(|(n, _)| n.clone()).collect();
    files
        .iter()
        .map(|(name, code)| {
            let mut deps = BTreeSet::new();
            for (i, _) in code.match_indices("super::") {
                let rest = &code[i + 7..];
                let word: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if names.contains(&word) {
                    deps.insert(word);
                }
                // `use super::{a::x, b::y}`
                if rest.starts_with('{') {
                    let group = &rest[1..rest.find('}').unwrap_or(1)];
                    for part in group.split(',') {
                        let word = part.trim().split("::").next().unwrap_or("").to_string();
                        if names.contains(&word) {
                            deps.insert(word);
                        }
                    }
                }
            }
            (name.clone(), deps)
        })
        .collect()
}

#[test]
fn diagnose_modules_import_no_circle() {
    let g = graph();
    assert!(g.len() >= 10, "{g:?}");
    // Kahn's algorithm: every module must come out of a topological order.
    let mut indegree: BTreeMap<&str, usize> = g.keys().map(|k| (k.as_str(), 0)).collect();
    for deps in g.values() {
        for d in deps {
            *indegree.get_mut(d.as_str()).expect("known module") += 1;
        }
    }
    let mut ready: Vec<&str> = indegree
        .iter()
        .filter(|(_, &n)| n == 0)
        .map(|(k, _)| *k)
        .collect();
    let mut done = 0;
    while let Some(m) = ready.pop() {
        done += 1;
        for d in &g[m] {
            let n = indegree.get_mut(d.as_str()).expect("known module");
            *n -= 1;
            if *n == 0 {
                ready.push(d.as_str());
            }
        }
    }
    let left: Vec<&str> = indegree
        .iter()
        .filter(|(_, &n)| n > 0)
        .map(|(k, _)| *k)
        .collect();
    assert_eq!(done, g.len(), "modules in a circle: {left:?}");
}
