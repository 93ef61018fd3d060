use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    grainflow::cli::main_with(grainflow::cli::Cli::parse())
}
