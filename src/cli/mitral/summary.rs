//! The summary of a mitral run on stdout.

use crate::app::mitral::inputs::OUTPUTS;
use crate::app::mitral::series::SERIES_CSV;
use crate::app::mitral::summary as report_summary;
use crate::organs::mitral::Report;
use std::path::Path;

/// One valve's summary paragraph and the files written into `out`.
pub(super) fn valve(report: &Report, out: &Path) {
    println!("{}", report_summary(report));
    for f in OUTPUTS {
        println!("wrote {}", out.join(f).display());
    }
}

/// A series' last line: `steps` steps written into `out` and its table.
pub(super) fn series(steps: usize, out: &Path) {
    println!(
        "wrote {steps} steps into {} and the table {}",
        out.display(),
        out.join(SERIES_CSV).display()
    );
}
