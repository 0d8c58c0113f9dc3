//! The hostile set (issue 18): generated bad files and flags run through
//! the binary — compression bombs, tangled and self-overlapping meshes,
//! runaway flags, malformed and truncated files. Every case must exit 1 or
//! 2 with one clear line, within its memory bound, leaving its inputs as
//! they were and nothing at its output (see `harness`). Run with
//! `--nocapture` for a log line per case (command, exit code, peak, message).

#![cfg(target_os = "linux")]

mod bombs;
mod flags;
mod harness;
mod malformed;
mod tangled;
