"""The Monte-Carlo study of a run's controllers, here or one plant per Dask task.

``MonteCarloStudy.of_run(run)`` takes the *recipe* of the study that ``track`` runs on the
twin (100 perturbed twins by default: stiffness, mass and α × U(0.8, 1.2), damping
U(0.5 %, 3 %), cross couplings up to 15 %, compensator parameters × U(0.8, 1.2), 0–2
samples of delay, sensor noise × 2; each perturbed twin measured in its own rig and every
controller designed from that measurement, as ``track`` designs on the nominal twin; a
plant passes when its RMS error per axis stays within 0.5 % of the range): the scenario,
the run-folder files the study reads, the controllers and the settings. The recipe
pickles; a process sets the study up from it once (the nominal twin) and keeps it, so :meth:`run` here and :func:`flexstage.sweeps.monte_carlo` on a cluster give the
same :class:`MonteCarlo`, bitwise: plant ``i`` depends on the seed and ``i`` alone.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _native
from .progress import reporter

_SETTINGS = ("plants", "duration", "rms_bound_pct", "seed", "spread", "coupling", "damping",
             "max_delay", "noise", "design")


@dataclass(frozen=True, eq=False)
class PlantResult:
    """One perturbed plant and every controller's result on it."""

    index: int
    #: Stiffness, mass and amplification factors.
    stiffness: float
    mass: float
    alpha: float
    #: Damping ratio of every mode.
    damping: float
    #: Cross couplings (c1, c2).
    coupling: Tuple[float, float]
    #: Delay [samples].
    delay: int
    #: RMS error per controller and axis [m] (∞ for a diverged run), shape (controllers, 2).
    rms: np.ndarray
    #: Whether each controller passed, shape (controllers,).
    passed: np.ndarray

    @staticmethod
    def from_native(d: Dict[str, Any]) -> "PlantResult":
        return PlantResult(index=d["index"], stiffness=d["stiffness"], mass=d["mass"],
                           alpha=d["alpha"], damping=d["damping"],
                           coupling=tuple(d["coupling"]), delay=d["delay"],
                           rms=np.array(d["rms"], dtype=np.float64).reshape(-1, 2),
                           passed=np.array(d["passed"], dtype=bool))


@dataclass(frozen=True, eq=False)
class MonteCarlo:
    """The study's result: one :class:`PlantResult` per plant, in plant order."""

    #: The controllers, in column order.
    controllers: Tuple[str, ...]
    plants: List[PlantResult] = field(default_factory=list)

    def pass_rate(self, controller: str) -> float:
        """The fraction of plants on which ``controller`` passed."""
        j = self.controllers.index(controller)
        return float(np.mean([p.passed[j] for p in self.plants])) if self.plants else 0.0


class MonteCarloStudy:
    """The recipe of a run's Monte-Carlo study (module docs); pickles for Dask."""

    def __init__(self, scenario_json: str, files: Dict[str, bytes],
                 controllers: Sequence[str], settings: Dict[str, Any]):
        unknown = set(settings) - set(_SETTINGS)
        if unknown:
            raise TypeError(f"unknown Monte-Carlo settings {sorted(unknown)} "
                            f"(settings: {', '.join(_SETTINGS)})")
        self.scenario_json = scenario_json
        self.files = dict(files)
        self.controllers = tuple(controllers)
        self.settings = {k: settings.get(k) for k in _SETTINGS}
        digest = hashlib.sha256(scenario_json.encode())
        for name in sorted(self.files):
            digest.update(name.encode())
            digest.update(self.files[name])
        digest.update(repr((self.controllers, sorted(self.settings.items()))).encode())
        self.key = digest.hexdigest()

    @staticmethod
    def of_run(run: Any, controllers: Optional[Sequence[str]] = None, progress: Any = True,
               **settings: Any) -> "MonteCarloStudy":
        """The study of ``run`` (a :class:`flexstage.Run` with a finished design; its
        identified parameters and PEAs are used when it has them), for ``controllers``
        (default: those of ``track``) and settings ``plants`` (100), ``duration`` [s] (0.5),
        ``rms_bound_pct`` (0.5), ``seed`` (18), ``spread`` (0.2), ``coupling`` (0.15),
        ``damping`` ((0.005, 0.03)), ``max_delay`` (2), ``noise`` (2: factor on the sensor
        noise), ``design`` (``"identified"``: each plant measured and every controller
        designed from its measurement; ``"nominal"``: the nominal twin's designs on every
        plant). Sets the study up here (the nominal twin and, for ``"nominal"``, the
        controllers designed from its measurement)."""
        scenario_json, files = run._n.study_recipe()
        ctrl = controllers or tuple(_native.DEFAULT_CONTROLLERS)
        study = MonteCarloStudy(scenario_json, files, ctrl, settings)
        study._native(progress)
        return study

    def _native(self, progress: Any = False) -> Any:
        return _native.MonteCarloStudy.build(self.key, self.scenario_json, self.files,
                                             list(self.controllers), self.settings,
                                             reporter(progress))

    @property
    def plants(self) -> int:
        """The number of plants."""
        return self.settings["plants"] or 100

    def plant(self, i: int) -> PlantResult:
        """Plant ``i`` (sets the study up in this process on first use)."""
        return PlantResult.from_native(self._native().plant(i))

    def run(self, progress: Any = True) -> MonteCarlo:
        """Every plant in this process, on its threads."""
        n = self._native(progress)
        plants = [PlantResult.from_native(d) for d in n.run(reporter(progress))]
        return MonteCarlo(controllers=self.controllers, plants=plants)

    def __repr__(self) -> str:
        return (f"<MonteCarloStudy {self.plants} plants x {len(self.controllers)} controllers, "
                f"key {self.key[:12]}>")
