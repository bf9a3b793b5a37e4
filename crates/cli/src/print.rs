//! Prints the pipeline's summaries (their `Display`, see `flexstage_pipeline::summary`):
//! results on standard output, warnings and where the results went on standard error.

use std::path::Path;

use flexstage_pipeline::summary::Summary;

/// "wrote DIR", noting replaced results.
pub fn wrote(dir: &Path, replaced: bool) {
    let note = ["", " (replacing its earlier results)"][replaced as usize];
    errln!("wrote {}{note}", dir.display());
}

/// A stage's summary: its result, its warnings, what it wrote.
pub fn summary(s: &impl Summary) {
    out!("{s}");
    for w in s.warnings() {
        errln!("warning: {w}");
    }
    let (written, replaced) = s.written();
    for path in written {
        wrote(path, replaced);
    }
}
