//! `tbm-thrust`: simulate the thrust cylinder, reproduce the paper, fit the model to bench
//! recordings and find the physics it misses. Every error is one line and a non-zero exit.

mod cli;

fn main() {
    std::process::exit(cli::main());
}
