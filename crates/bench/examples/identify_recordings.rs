//! Writes the synthetic bench recordings that docs/identify.md compares the two `identify`
//! methods on (made with the model itself, truth beta_e = 1.3e9 Pa, C_ip = 1.5e-12
//! m^3/(s Pa), b = 5000 N s/m, noise as in the tests):
//!
//! `cargo run --release --example identify_recordings -- DIR`
//!
//! - `paper_single.csv`: the paper's identification run (section 2.3), single pump, PID,
//!   0.05 m/s from rest, 12 kN, 20 s;
//! - `steps_single.csv`: single pump, 20 s with a speed step up, a load step and a speed step
//!   down;
//! - `steps_adaptive.csv`: the same with the adaptive dual-pump scheme.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{noisy_recording, scenario, truth};
use tbm_thrust::Scenario;

fn main() {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&dir).expect("create the output directory");
    let runs = [
        (
            "paper_single.csv",
            "single",
            Scenario::startup(0.05, 12_000.0),
        ),
        ("steps_single.csv", "single", scenario(20.0)),
        ("steps_adaptive.csv", "adaptive", scenario(20.0)),
    ];
    for (seed, (file, scheme, sc)) in runs.into_iter().enumerate() {
        let path = dir.join(file);
        std::fs::write(
            &path,
            noisy_recording(&truth(scheme), &sc, 100 + seed as u64).to_csv(),
        )
        .expect("write the recording");
        println!("{}", path.display());
    }
}
