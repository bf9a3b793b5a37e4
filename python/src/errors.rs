//! Errors as Python exceptions with the CLI's text.
//!
//! The CLI prints `error: {e:#}`: the error and each of its causes once, joined by ": "
//! (anyhow's alternate form). [`chain`] builds the same text, so a message a user reads in
//! a notebook is the one the command line prints, and the one the documentation quotes.

use flexstage_pipeline::PipelineError;
use pyo3::exceptions::{PyException, PyKeyboardInterrupt};
use pyo3::prelude::*;

pyo3::create_exception!(
    flexstage,
    FlexstageError,
    PyException,
    "Base of every flexstage error. The message is the command line's (each cause once)."
);
pyo3::create_exception!(
    flexstage,
    ScenarioError,
    FlexstageError,
    "A scenario that does not parse or validate: the message names the field, the value and \
     the accepted range."
);
pyo3::create_exception!(
    flexstage,
    OptionError,
    FlexstageError,
    "A stage option out of its accepted range (named as `<stage>.<option>`)."
);
pyo3::create_exception!(
    flexstage,
    RunFolderError,
    FlexstageError,
    "The run folder refuses the call: a result that would be replaced, a missing input, a \
     folder of another scenario, a folder another process holds, a damaged file."
);

/// The error and its causes, each once, joined by ": " (the CLI's `{e:#}`).
pub fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}

/// A pipeline error as the Python exception of its kind; an interruption
/// ([`PipelineError::Interrupted`]) is a `KeyboardInterrupt`.
pub fn pipeline(e: PipelineError) -> PyErr {
    let text = chain(&e);
    match e {
        PipelineError::Interrupted { .. } => PyKeyboardInterrupt::new_err(text),
        PipelineError::Scenario(_) => ScenarioError::new_err(text),
        PipelineError::Option { .. } => OptionError::new_err(text),
        PipelineError::Exists { .. }
        | PipelineError::Missing { .. }
        | PipelineError::OtherScenario { .. }
        | PipelineError::Locked { .. }
        | PipelineError::Damaged { .. }
        | PipelineError::Read { .. }
        | PipelineError::ForeignParams { .. }
        | PipelineError::Run(_) => RunFolderError::new_err(text),
        _ => FlexstageError::new_err(text),
    }
}

/// A scenario that cannot be loaded, as the CLI says it: `invalid scenario: <causes>`.
pub fn scenario(e: &(dyn std::error::Error + 'static)) -> PyErr {
    ScenarioError::new_err(format!("invalid scenario: {}", chain(e)))
}

/// A run-crate error (reading a result file).
pub fn run(e: flexstage_run::RunError) -> PyErr {
    pipeline(PipelineError::Run(e))
}

/// Registers the exception classes in the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("FlexstageError", py.get_type::<FlexstageError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("OptionError", py.get_type::<OptionError>())?;
    m.add("RunFolderError", py.get_type::<RunFolderError>())?;
    Ok(())
}
