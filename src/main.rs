//! The `unfold` command-line tool.

use unfold::cli;

use clap::Parser;
use clap::error::ErrorKind;
use std::process::ExitCode;

/// mimalloc instead of the system allocator: the pipelines allocate and
/// free many short-lived buffers (sparse patterns, factors, per-element
/// arrays), and with glibc's allocator each run pays page faults for them
/// again (the mitral bench valve: 23.9 -> 22.2 ms). The benches use it too,
/// so they measure what the command runs.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// A clap parse error as one line: the message lines before the usage
/// block, joined, without clap's `error: ` prefix.
fn one_line_usage_error(e: &clap::Error) -> String {
    let text = e.to_string();
    let msg: Vec<&str> = text
        .lines()
        .map(str::trim)
        .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
        .filter(|l| !l.is_empty())
        .collect();
    let msg = msg.join(" ");
    let msg = msg.strip_prefix("error: ").unwrap_or(&msg);
    format!("{msg} (see --help)")
}

fn main() -> ExitCode {
    let args = match cli::Cli::try_parse() {
        Ok(args) => args,
        Err(e) => match e.kind() {
            // Help and version go to stdout as clap prints them.
            ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => e.exit(),
            _ => {
                let msg = one_line_usage_error(&e);
                eprintln!("unfold: error: {}", cli::printable(&msg));
                cli::write_peak_file();
                return ExitCode::from(2);
            }
        },
    };
    let code = match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line on stderr, so scripts and users see exactly what failed.
            let msg = e.to_string();
            eprintln!("unfold: error: {}", cli::printable(&msg));
            // 3: outputs written, but the solver did not converge
            if matches!(e, cli::CliError::NotConverged { .. }) {
                ExitCode::from(3)
            } else {
                ExitCode::FAILURE
            }
        }
    };
    cli::write_peak_file();
    code
}
