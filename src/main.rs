//! The `unfold` command-line tool.

use std::process::ExitCode;

/// mimalloc instead of the system allocator: the pipelines allocate and
/// free many short-lived buffers (sparse patterns, factors, per-element
/// arrays), and with glibc's allocator each run pays page faults for them
/// again (the mitral bench valve: 23.9 -> 22.2 ms). The benches use it too,
/// so they measure what the command runs.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    ExitCode::from(unfold::cli::main(std::env::args_os().collect()))
}
