//! The diagnosis reads in one direction: no module of `src/diagnose/` reaches, through
//! `super::` paths, a module that reaches it back (no import circles); the pipeline's stages
//! run in one direction, each reaching only earlier stages and the modules they are built from.

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

/// The pipeline's stages in the order `diagnose_reporting` runs them.
const STAGES: [&str; 6] = [
    "prepare",
    "refit",
    "propose",
    "whole",
    "attribute",
    "report",
];

fn source(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("src/diagnose")
        .join(format!("{name}.rs"));
    std::fs::read_to_string(path).expect("readable")
}

#[test]
fn no_stage_imports_a_later_stage() {
    let g = graph();
    for (i, stage) in STAGES.iter().enumerate() {
        let deps = g
            .get(*stage)
            .unwrap_or_else(|| panic!("stage {stage} missing"));
        let later: Vec<&&str> = STAGES[i + 1..]
            .iter()
            .filter(|s| deps.contains(**s))
            .collect();
        assert!(later.is_empty(), "{stage} imports {later:?}");
    }
}

#[test]
fn what_the_stages_are_built_from_imports_no_stage() {
    let g = graph();
    // Every module a stage reaches, directly or through other support modules.
    let mut support: BTreeSet<&str> = BTreeSet::new();
    let mut todo: Vec<&str> = STAGES
        .iter()
        .flat_map(|s| g[*s].iter().map(String::as_str))
        .collect();
    while let Some(m) = todo.pop() {
        if !STAGES.contains(&m) && support.insert(m) {
            todo.extend(g[m].iter().map(String::as_str));
        }
    }
    assert!(support.len() >= 8, "{support:?}");
    for m in support {
        let stages: Vec<&String> = g[m]
            .iter()
            .filter(|d| STAGES.contains(&d.as_str()))
            .collect();
        assert!(stages.is_empty(), "{m} imports the stages {stages:?}");
    }
}

#[test]
fn each_stage_has_one_entry_point_and_runs_in_order() {
    for stage in STAGES {
        let code = source(stage);
        let code = code.split("#[cfg(test)]").next().unwrap_or("");
        let entries = code.lines().filter(|l| l.starts_with("pub fn ")).count();
        assert_eq!(entries, 1, "{stage} has {entries} public functions");
    }
    let body = source("mod");
    let body = &body[body
        .find("pub fn diagnose_reporting")
        .expect("diagnose_reporting")..];
    let calls: Vec<usize> = STAGES
        .iter()
        .map(|s| {
            body.find(&format!("{s}::"))
                .unwrap_or_else(|| panic!("diagnose_reporting does not call {s}"))
        })
        .collect();
    assert!(calls.windows(2).all(|w| w[0] < w[1]), "{calls:?}");
}
