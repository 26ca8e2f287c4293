//! The model crate is what the FMU carries: its normal dependency tree must hold nothing for
//! fitting, plotting, progress bars, threads or random numbers (those belong to
//! `crates/bench` and `crates/cli`). The cdylib's dynamic imports are checked in
//! `tests/fmu_package.rs` (`library_needs_only_the_c_runtime`).

use std::process::Command;

/// Crates that must never reach the model crate's dependency tree.
const FORBIDDEN: &[&str] = &[
    "rayon",
    "indicatif",
    "clap",
    "plotters",
    "rand",
    "nalgebra",
    "tbm-bench",
];

#[test]
fn model_crate_depends_on_nothing_for_fitting_plotting_or_threads() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["tree", "--offline", "-p", "tbm-thrust", "-e", "normal"])
        .args(["--prefix", "none", "--format", "{p}"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cargo tree");
    let tree = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let names: Vec<&str> = tree
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(names.contains(&"tbm-thrust"), "cargo tree printed:\n{tree}");
    for bad in FORBIDDEN {
        assert!(
            !names.contains(bad),
            "the model crate depends on {bad}:\n{tree}"
        );
    }
}
