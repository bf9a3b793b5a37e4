"""flexstage: a topology-optimized compliant positioning stage from design to tracking
control, for Python.

The stages of the ``flexstage`` command line (Actuators 2022, 11(7), 179: design → export →
reduce → twin → PEA and stage identification → tracking → report) on a run folder, with
typed results whose arrays are numpy arrays::

    import flexstage as fs
    s = fs.Scenario.preset("quick")
    s.optimization.max_iterations = 40        # validated at once, as `flexstage check`
    with fs.Run(s, "runs/nb") as run:
        design = run.design(force=True)
        design.density                        # (nl, nw) densities, no copy
        tracking = run.track(trajectory="circle", controllers=["pi-notch-ff"])

``flexstage.sweeps`` sends design sweeps and the Monte-Carlo study to a Dask cluster.
Errors are :class:`FlexstageError` (and its subclasses) with the command line's text;
Ctrl-C stops a long call cleanly with ``KeyboardInterrupt``.
"""

from ._native import (CONTROLLERS, DEFAULT_CONTROLLERS, DEFAULT_PRESET, PRESETS, FlexstageError,
                      OptionError, RunFolderError, ScenarioError)
from .results import (Analysis, Design, Export, PeaIdentification, PeaRecord, Reduction,
                      RunSummary, StageIdentification, TrackCase, Tracking, Twin, same)
from .run import Run
from .scenario import Scenario
from .study import MonteCarlo, MonteCarloStudy, PlantResult

__all__ = [
    "CONTROLLERS", "DEFAULT_CONTROLLERS", "DEFAULT_PRESET", "PRESETS", "FlexstageError",
    "OptionError", "RunFolderError", "ScenarioError", "Analysis", "Design", "Export",
    "PeaIdentification", "PeaRecord", "Reduction", "RunSummary", "StageIdentification",
    "TrackCase", "Tracking", "Twin", "same", "Run", "Scenario", "MonteCarlo", "MonteCarloStudy", "PlantResult",
]
