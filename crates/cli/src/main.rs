//! `tbm-thrust`: simulate the thrust cylinder, reproduce the paper, fit the model to bench
//! recordings and find the physics it misses. One module per subcommand; each returns
//! `Result<(), String>` whose error is printed as one line with a non-zero exit.

mod diagnose;
mod generate;
mod identify;
mod plot;
mod reproduce;
mod simulate;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "tbm-thrust",
    version,
    about = "TBM thrust cylinder with two pumps: simulate, reproduce the paper, identify, diagnose"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// One run of the model; writes a recording CSV and prints the metrics.
    Simulate(simulate::Args),
    /// Every comparison of the paper's sections 3.3 and 4: figures, report, JSON.
    Reproduce(reproduce::Args),
    /// Fit the model's unknowns to a recording.
    Identify(identify::Args),
    /// Refit, locate the mismatch, name and model the missing physics.
    Diagnose(diagnose::Args),
    /// Write synthetic bench recordings with concealed effects.
    Generate(generate::Args),
}

fn main() {
    std::process::exit(run());
}

fn run() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    let result = match cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Reproduce(a) => reproduce::run(a),
        Command::Identify(a) => identify::run(a),
        Command::Diagnose(a) => diagnose::run(a),
        Command::Generate(a) => generate::run(a),
    };
    match result {
        Ok(()) => 0,
        Err(msg) => {
            eprintln!("error: {msg}");
            1
        }
    }
}
