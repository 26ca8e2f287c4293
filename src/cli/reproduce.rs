//! `tbm-thrust reproduce` (being written in this session).

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`reproduce` is not available in this build yet".into())
}
