//! The `unfold` command-line tool.

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line on stderr, so scripts and users see exactly what failed.
            let msg = e.to_string().replace('\n', " ");
            eprintln!("unfold: error: {msg}");
            ExitCode::FAILURE
        }
    }
}
