//! `flexstage._native`: the pyo3 module behind the `flexstage` Python package.
//!
//! A thin typed layer over `flexstage-pipeline` and the typed run files of `flexstage-run`:
//! scenarios (`scenario`), a run folder and its stages (`run`), results read back through
//! the typed files as zero-copy numpy views (`results`, `arrays`), long calls without the
//! GIL with progress and Ctrl-C (`work`), and the Monte-Carlo study one plant at a time for
//! a Dask cluster (`study`). Errors carry the command line's text (`errors`). The Python
//! package (`python/flexstage/`) adds the result classes, progress bars and the Dask sweeps.

mod arrays;
mod errors;
mod results;
mod run;
mod scenario;
mod study;
mod work;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<scenario::PyScenario>()?;
    m.add_class::<run::PyRun>()?;
    m.add_class::<arrays::Buffer>()?;
    m.add_class::<study::PyStudy>()?;
    m.add("PRESETS", flexstage_pipeline::PRESETS.to_vec())?;
    m.add("DEFAULT_PRESET", flexstage_pipeline::DEFAULT_PRESET)?;
    // The registry's controllers by name, and those `track` runs by default.
    let names = |cs: &[&flexstage_pipeline::Controller]| -> Vec<&'static str> {
        cs.iter().map(|c| c.name).collect()
    };
    m.add("CONTROLLERS", names(&flexstage_pipeline::CONTROLLERS))?;
    m.add(
        "DEFAULT_CONTROLLERS",
        names(&flexstage_pipeline::Controller::defaults()),
    )?;
    Ok(())
}
