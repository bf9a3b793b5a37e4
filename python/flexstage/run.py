"""A run folder and the pipeline's stages on it.

``Run(scenario)`` opens (creating) ``runs/<scenario name>/`` and holds its lock until
:meth:`Run.close` (or the end of a ``with`` block): one process per folder, as on the command
line. Each stage method calls the same pipeline function with the same defaults as its
``flexstage`` subcommand, releases the GIL while it works, shows progress (tqdm where
installed; ``progress=False`` for none) and stops cleanly on Ctrl-C (``KeyboardInterrupt``;
an interrupted design leaves its checkpoint: ``design(resume=True)`` continues it). Every
stage returns its typed result, read back from the folder's typed files; the ``load_*``
methods read the same results from a folder made earlier (by Python or the CLI).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from .progress import reporter
from .results import (Analysis, Design, Export, PeaIdentification, PeaRecord, Reduction,
                      RunSummary, StageIdentification, StageResult, TrackCase, Tracking, Twin)
from .scenario import Scenario

PathLike = Union[str, Path]


def _floats(a: Any, name: str) -> List[float]:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, it has shape {arr.shape}")
    return arr.tolist()


def _common(outcome: Tuple[str, List[str], List[str]]) -> Dict[str, Any]:
    text, warnings, _written = outcome
    return {"text": text, "warnings": tuple(warnings)}


class Run:
    """A run folder (``runs/<scenario name>/`` unless ``path`` is given) for ``scenario``
    (default: the quick preset). A folder that records another scenario is refused unless
    ``replace``. Use :meth:`open` for an existing folder with its own scenario."""

    def __init__(self, scenario: Optional[Scenario] = None, path: Optional[PathLike] = None,
                 replace: bool = False):
        scenario = scenario if scenario is not None else Scenario.preset("quick")
        self._n = _native.Run(scenario._native, None if path is None else str(path), replace)

    @classmethod
    def open(cls, path: PathLike) -> "Run":
        """An existing run folder, with the scenario recorded in it."""
        run = cls.__new__(cls)
        run._n = _native.Run.existing(str(path))
        return run

    # -- the folder ---------------------------------------------------------------------
    @property
    def path(self) -> Path:
        """The run folder."""
        return Path(self._n.path)

    @property
    def scenario(self) -> Scenario:
        """A copy of the run's scenario."""
        return Scenario(self._n.scenario)

    @property
    def notices(self) -> List[str]:
        """What opening the folder did (a stale lock taken over, temporaries removed)."""
        return list(self._n.notices)

    def close(self) -> None:
        """Releases the folder's lock; the object cannot be used afterwards."""
        self._n.close()

    def __enter__(self) -> "Run":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        try:
            return f"<Run {str(self.path)!r}>"
        except Exception:
            return "<Run (closed)>"

    # -- stages -------------------------------------------------------------------------
    def design(self, *, force: bool = False, resume: bool = False,
               max_iterations: Optional[int] = None, checkpoint_every: Optional[int] = None,
               snapshot_every: Optional[int] = None, progress: Any = True) -> Design:
        """Workspace topology optimization (paper Section 2.2, Algorithm 1): ``flexstage
        design``. A finished or interrupted design is replaced only with ``force``;
        ``resume`` continues an interrupted one from its checkpoint."""
        out = self._n.design(reporter(progress), force, resume, max_iterations,
                             checkpoint_every, snapshot_every)
        return self._design(**_common(out))

    def analyze(self, *, design: Optional[str] = None,
                inputs: Optional[Iterable[Sequence[float]]] = None,
                progress: Any = False) -> Analysis:
        """Nonlinear statics of a design (``flexstage analyze``): the run's design (or
        ``design="uniform"``, ``"uniform:0.5"``, a file, another run folder); ``inputs``:
        input pairs (x_nom1, x_nom2) [m], else the workspace samples."""
        pairs = [tuple(float(v) for v in p) for p in (inputs or [])]
        out, name = self._n.analyze(reporter(progress), design, pairs)
        return self._analysis(name, **_common(out))

    def export(self, *, design: Optional[str] = None, unit: str = "mm",
               level: Optional[float] = None, smoothing: Optional[int] = None,
               max_chord: Optional[float] = None, verify: bool = True,
               fatigue_strength: Optional[float] = None, safety_factor: Optional[float] = None,
               min_ligament: Optional[float] = None, min_gap: Optional[float] = None,
               start_hole_diameter: Optional[float] = None, progress: Any = False) -> Export:
        """The manufacturing outline (DXF, SVG, STL) and its body-fitted verification
        (``flexstage export``). Lengths in metres, stresses in pascals; limits default to
        the scenario's ``[limits]``."""
        limits = [fatigue_strength, safety_factor, min_ligament, min_gap, start_hole_diameter]
        out, safe = self._n.export(reporter(progress), design, unit, level, smoothing,
                                   max_chord, verify, limits)
        return self._export(safe=safe if verify else None, **_common(out))

    def reduce(self, *, design: Optional[str] = None,
               operating_point: Optional[Sequence[float]] = None, modes: Optional[int] = None,
               lumped: bool = False, plate_masses: bool = True,
               scales: Optional[Sequence[float]] = None, keep_output_spring: bool = False,
               progress: Any = True) -> Reduction:
        """The reduced spring–mass model (Section 3.2.1, ``flexstage reduce``); its
        parameters become the run's simulated stage. ``operating_point``: nominal strokes
        [m]."""
        op = None if operating_point is None else tuple(float(v) for v in operating_point)
        sc = None if scales is None else [float(v) for v in scales]
        out = self._n.reduce(reporter(progress), design, op, modes, lumped, plate_masses, sc,
                             keep_output_spring)
        return self._reduction(**_common(out))

    def twin(self, *, validation: str = "auto", progress: Any = True) -> Twin:
        """The digital twin's report data (``flexstage track --write-twin``): modes, the
        frequency response beside the lumped model, the check against the full nonlinear
        transient (``validation``: "auto", "on", "off")."""
        out = self._n.twin(reporter(progress), validation)
        return self._twin(**_common(out))

    def simulate_pea(self, pea: int = 1, *, shape: str = "decaying",
                     frequency: Optional[float] = None, cycles: Optional[int] = None,
                     noise_nm: Optional[float] = None, dt: Optional[float] = None,
                     seed: Optional[int] = None, write: bool = True) -> PeaRecord:
        """A simulated record of PEA ``pea`` (Bouc–Wen, Eq. 18, Table A1; ``flexstage pea
        simulate``), written to the run folder unless ``write=False``."""
        text, arrays, written = self._n.simulate_pea(pea, shape, frequency, cycles, noise_nm,
                                                     dt, seed, write)
        folder = Path(written[0]).parent if written else self.path
        return PeaRecord(folder=folder, text=text, pea=pea, **arrays)

    def identify_pea(self, pea: int = 1, data: Any = None, *, t: Any = None, u: Any = None,
                     x: Any = None, forgetting: Optional[float] = None,
                     passes: Optional[int] = None) -> PeaIdentification:
        """Bouc–Wen parameters of PEA ``pea`` (Appendix B; ``flexstage identify pea``) from
        the run's record, a CSV file (``data``: path), a :class:`PeaRecord` (``data``), or
        arrays ``t`` [s], ``u`` [V], ``x`` [µm]."""
        path = None
        arrays = None
        if isinstance(data, PeaRecord):
            t, u, x = data.t, data.u, data.x
        elif data is not None:
            path = str(data)
        if t is not None or u is not None or x is not None:
            if t is None or u is None or x is None:
                raise ValueError("give all three arrays t [s], u [V], x [µm]")
            arrays = (_floats(t, "t"), _floats(u, "u"), _floats(x, "x"))
        out = self._n.identify_pea(pea, path, arrays, forgetting, passes)
        return self._pea_identification(pea, **_common(out))

    def identify_stage(self, data: Any = None, *, plant: str = "lumped",
                       duration: Optional[float] = None, f_max: Optional[float] = None,
                       resonance_amplitude: Optional[float] = None, linear: bool = False,
                       noise: bool = True, forgetting: Optional[float] = None,
                       prefilter: Optional[float] = None, decimation: Optional[int] = None,
                       scheme: Optional[str] = None, coupling: bool = True,
                       progress: Any = True) -> StageIdentification:
        """Stage parameters (Section 4.2, Eq. 54–56; ``flexstage identify stage``): by a
        simulated multisine on ``plant`` ("lumped", or "twin": its response fit), or from
        ``data``: a record file, or a mapping of arrays ``t`` [s], ``x_nom1``, ``x_nom2``
        [m] (or ``U1``, ``U2`` [V]), ``x_in1``, ``x_in2``, ``q1``, ``q2`` [m]."""
        path = None
        columns = None
        voltage = False
        if isinstance(data, dict):
            voltage = "U1" in data and "x_nom1" not in data
            inputs = ("U1", "U2") if voltage else ("x_nom1", "x_nom2")
            names = ("t",) + inputs + ("x_in1", "x_in2", "q1", "q2")
            missing = [n for n in names if n not in data]
            if missing:
                raise KeyError(f"stage record arrays: missing {', '.join(missing)} "
                               f"(need {', '.join(names)})")
            columns = [_floats(data[n], n) for n in names]
        elif data is not None:
            path = str(data)
        estimator = (forgetting, prefilter, decimation, scheme, coupling)
        out = self._n.identify_stage(reporter(progress), path, columns, voltage, plant,
                                     duration, f_max, resonance_amplitude, linear, noise,
                                     estimator)
        return self._stage_identification(**_common(out))

    def track(self, *, trajectory: Optional[str] = None,
              controllers: Optional[Sequence[str]] = None, compensation: str = "inverse",
              params: Optional[PathLike] = None, allow_foreign_params: bool = False,
              duration: Optional[float] = None, plant: str = "twin",
              learning: Optional[int] = None, montecarlo_plants: Optional[int] = None,
              progress: Any = True) -> Tracking:
        """The simulated tracking experiment (Section 4, Figures 9–11; ``flexstage track``):
        ``trajectory`` of the scenario (default all), ``controllers`` among the registry's
        (``flexstage.CONTROLLERS``; default ``flexstage.DEFAULT_CONTROLLERS``) on
        the twin (``plant="lumped"``: the 8-state model). ``learning``: also run every
        controller with iterative learning for that many trials (periodic trajectories
        only; ``flexstage track --learning --trials N``), rows ``<controller>+learning``.
        ``montecarlo_plants``: perturbed twins of the Monte-Carlo study on the twin, ≥ 1
        (default 100, each measured in its rig and designed on: seconds apiece;
        ``flexstage track --montecarlo-plants N``)."""
        ctrl = None if controllers is None else [str(c) for c in controllers]
        out, conditions = self._n.track(reporter(progress), plant, trajectory, ctrl,
                                        compensation, None if params is None else str(params),
                                        allow_foreign_params, duration, learning,
                                        montecarlo_plants)
        return self._tracking(conditions, **_common(out))

    def report(self) -> Path:
        """Writes the self-contained ``report.html`` (``flexstage report``); returns it."""
        return Path(self._n.report())

    def run(self, *, restart: bool = False, progress: Any = True) -> RunSummary:
        """Every stage in order (``flexstage run``), resuming after the stages finished
        earlier with the same scenario and options; ``restart`` starts over."""
        text, report, verdict = self._n.run(reporter(progress), restart)
        return RunSummary(text=text, report=Path(report), verdict=verdict)

    # -- results of the folder ----------------------------------------------------------
    def load_design(self) -> Optional[Design]:
        """The run's finished design, or None."""
        return self._design() if self._n.load_design() is not None else None

    def load_analysis(self, name: str = "workspace") -> Optional[Analysis]:
        """The analysis in ``analyze/<name>/``, or None."""
        try:
            return self._analysis(name)
        except LookupError:
            return None

    def load_export(self) -> Optional[Export]:
        """The exported outline and its verification, or None."""
        return self._optional(self._export)

    def load_reduction(self) -> Optional[Reduction]:
        """The reduced model, or None."""
        return self._optional(self._reduction)

    def load_twin(self) -> Optional[Twin]:
        """The twin's report data, or None."""
        return self._optional(self._twin)

    def load_pea_record(self, pea: int = 1) -> Optional[PeaRecord]:
        """The run's simulated record of PEA ``pea``, or None."""
        d = self._n.load_pea_record(pea)
        return None if d is None else PeaRecord(folder=self.path, pea=pea, **d)

    def load_pea_identification(self, pea: int = 1) -> Optional[PeaIdentification]:
        """The identification of PEA ``pea``, or None."""
        return self._optional(lambda: self._pea_identification(pea))

    def load_stage_identification(self) -> Optional[StageIdentification]:
        """The stage identification, or None."""
        return self._optional(self._stage_identification)

    def load_tracking(self, conditions: str = "") -> Optional[Tracking]:
        """The tracking results of ``track/`` (or ``track/<conditions>/``), or None."""
        return self._optional(lambda: self._tracking(conditions))

    # -- building results from the typed files ------------------------------------------
    @staticmethod
    def _optional(make: Any) -> Any:
        try:
            return make()
        except LookupError:
            return None

    @staticmethod
    def _need(d: Optional[Dict[str, Any]], what: str) -> Dict[str, Any]:
        if d is None:
            raise LookupError(f"the run folder has no {what}")
        return d

    def _design(self, **common: Any) -> Design:
        d = self._need(self._n.load_design(), "finished design")
        mesh = self._n.scenario.get(["mesh"])
        return Design(folder=Path(d.pop("folder")), size=(mesh["length"], mesh["width"]),
                      **d, **common)

    def _analysis(self, name: str, **common: Any) -> Analysis:
        d = self._need(self._n.load_analysis(name), f"analysis {name!r}")
        return Analysis(folder=Path(d.pop("folder")), name=name, **d, **common)

    def _export(self, safe: Optional[bool] = None, **common: Any) -> Export:
        d = self._need(self._n.load_export(), "exported outline")
        v = d["verification"]
        if safe is None and v is not None:
            safe = bool(v.get("verdict", {}).get("safe", False))
        files = {k: Path(p) for k, p in d["files"].items()}
        return Export(folder=Path(d["folder"]), files=files, verification=v, safe=safe,
                      **common)

    def _reduction(self, **common: Any) -> Reduction:
        d = self._need(self._n.load_reduction(), "reduced model")
        nodes, shapes = _mode_shapes(d.pop("mode_shapes"))
        return Reduction(folder=Path(d.pop("folder")), nodes=nodes, mode_shapes=shapes, **d,
                         **common)

    def _twin(self, **common: Any) -> Twin:
        d = self._need(self._n.load_twin(), "twin data")
        return Twin(folder=Path(d.pop("folder")), **d, **common)

    def _pea_identification(self, pea: int, **common: Any) -> PeaIdentification:
        d = self._need(self._n.load_pea_identification(pea), f"identification of PEA {pea}")
        return PeaIdentification(folder=Path(d.pop("folder")), **d, **common)

    def _stage_identification(self, **common: Any) -> StageIdentification:
        d = self._need(self._n.load_stage_identification(), "stage identification")
        return StageIdentification(folder=Path(d.pop("folder")), **d, **common)

    def _tracking(self, conditions: str, **common: Any) -> Tracking:
        d = self._need(self._n.load_tracking(conditions), "tracking results")
        cases = {key: TrackCase(key[0], key[1], series)
                 for key, series in d.pop("series").items()}
        return Tracking(folder=Path(d.pop("folder")), conditions=conditions, cases=cases,
                        **d, **common)


def _mode_shapes(table: Optional[Dict[str, np.ndarray]]
                 ) -> Tuple[Optional[np.ndarray], Optional[np.ndarray]]:
    if table is None:
        return None, None
    nodes = np.column_stack([table["x_m"], table["y_m"]])
    k = 1
    shapes = []
    while f"ux_{k}" in table:
        shapes.append(np.column_stack([table[f"ux_{k}"], table[f"uy_{k}"]]))
        k += 1
    return nodes, (np.stack(shapes) if shapes else np.zeros((0, len(nodes), 2)))
