"""Typed results of the pipeline's stages.

Every class is built from a run folder's typed files (read by the native layer through
``flexstage-run``), so a stage just run and a folder opened later give the same objects.
Arrays are numpy arrays; the density field and every time series are read-only views of the
run folder's values (no copy: ``np.array(a)`` gives a writable copy). Units are SI unless a
field says otherwise. Objects pickle (for Dask) and compare with :func:`same`.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

Table = Mapping[str, np.ndarray]
"""Named columns (the file's header names, units in the names), each a 1-D array."""

Records = List[Dict[str, Any]]
"""Rows of a table of typed rows (one dict per row, numbers as floats)."""


@dataclass(frozen=True, eq=False)
class StageResult:
    """What every stage result has: the stage's folder, the summary the CLI prints (empty
    for a result opened from a folder) and its warnings."""

    folder: Path
    text: str = field(default="", repr=False)
    warnings: Tuple[str, ...] = ()

    def __str__(self) -> str:
        return self.text or repr(self)


@dataclass(frozen=True, eq=False)
class Design(StageResult):
    """The finished design (paper Section 2.2, Algorithm 1).

    ``density[i, j]`` is the physical density ρ ∈ [0, 1] of element column ``i`` (from the
    left, along x) and row ``j`` (from the bottom, along y): shape ``(nl, nw)``. Plot it with
    ``plt.imshow(d.density.T, origin="lower", extent=d.extent, cmap="gray_r")``.
    """

    density: np.ndarray = None  # type: ignore[assignment]
    #: Domain (length, width) [m].
    size: Tuple[float, float] = (0.0, 0.0)
    #: Workspace area of the design, final nonlinear analysis (Eq. 4) [m²].
    area: float = math.nan
    #: Workspace area of the uniform start design [m²].
    area_initial: float = math.nan
    #: Design iterations (all sessions).
    iterations: int = 0
    #: Fraction of design elements with 0.1 < ρ < 0.9.
    grey_fraction: float = math.nan
    #: What the design delivers: ``alpha`` (Eq. 24–27), ``theta_deg``, ``mass`` [kg],
    #: ``peak_stress`` [Pa], ``allowable_stress`` [Pa], ``thinnest_member`` [m],
    #: ``narrowest_gap`` [m], ``first_frequency_hz``, ``area_eroded``/``area_dilated`` [m²], …
    record: Optional[Dict[str, Any]] = None
    #: The stage summary (stop reason, iterations, seconds, constraints g ≤ 0 by name, …).
    summary: Optional[Dict[str, Any]] = None
    #: Output workspace polygon of the start design, (n, 2) [m] (Figure 4).
    workspace_initial: Optional[np.ndarray] = None
    #: Output workspace polygon of the design, (n, 2) [m] (Figure 4).
    workspace_final: Optional[np.ndarray] = None
    #: Iteration history (``area_m2``, ``objective``, ``g_<constraint>``, ``grey``, ``beta``,
    #: ``time_s``, …), one value per iteration.
    history: Optional[Table] = None
    #: Per-load-case table of the final analysis.
    cases: Optional[Table] = None

    @property
    def extent(self) -> Tuple[float, float, float, float]:
        """``(0, length, 0, width)`` [m], for ``imshow``."""
        return (0.0, self.size[0], 0.0, self.size[1])


@dataclass(frozen=True, eq=False)
class Analysis(StageResult):
    """A nonlinear static analysis (``analyze/<name>/``)."""

    #: The analysis folder's name (``workspace``, ``inputs_30_-30``, …).
    name: str = ""
    #: Design analysed, cases, Newton iterations, seconds, ``area_m2`` (workspace analyses).
    summary: Optional[Dict[str, Any]] = None
    #: One row per load case: inputs and output displacements.
    cases: Optional[Table] = None


@dataclass(frozen=True, eq=False)
class Export(StageResult):
    """The manufacturing outline and its body-fitted verification (Section 4.1)."""

    #: Paths of the outline files: ``dxf``, ``svg``, ``stl``.
    files: Dict[str, Path] = field(default_factory=dict)
    #: The verification (SI units): body-fitted stress, α, frequencies, manufacturability
    #: findings, ``verdict``; None when skipped.
    verification: Optional[Dict[str, Any]] = None
    #: Whether the verdict is "safe" (None when not verified).
    safe: Optional[bool] = None


@dataclass(frozen=True, eq=False)
class Reduction(StageResult):
    """The reduced spring–mass model (Section 3.2.1)."""

    #: α (Eq. 24), θ, stiffnesses, mass, frequencies, Assumption 2, validity.
    summary: Dict[str, Any] = field(default_factory=dict)
    #: The stage parameters (``params``: Eq. 31–35), the run's simulated stage from now on.
    params: Optional[Dict[str, Any]] = None
    #: ``mode``, ``frequency_hz``, ``residual``.
    modes: Optional[Table] = None
    #: Node coordinates (n_nodes, 2) [m].
    nodes: Optional[np.ndarray] = None
    #: Mode shapes (modes, n_nodes, 2), mass-normalized (φᵀMφ = 1).
    mode_shapes: Optional[np.ndarray] = None
    #: The validity map of the tangent model against nonlinear FE.
    validity: Optional[Table] = None
    #: Its error per stroke scale.
    validity_scale: Optional[Table] = None

    @property
    def frequencies(self) -> Optional[np.ndarray]:
        """Natural frequencies [Hz]."""
        return None if self.modes is None else self.modes["frequency_hz"]


@dataclass(frozen=True, eq=False)
class Twin(StageResult):
    """The digital twin's report data: modes, frequency response, validity."""

    #: Order, modes, damping, check against the full nonlinear transient.
    validity: Dict[str, Any] = field(default_factory=dict)
    #: Twin against FE modal frequencies.
    modes: Optional[Records] = None
    #: Frequency response x_nom_j → q_i: ``f_Hz``, then ``<model>_q<i>_x<j>_dB`` and ``_deg``
    #: (magnitude and phase) of the twin and of the lumped model.
    bode: Optional[Table] = None

    def frequency_response(self, output: int, input: int, model: str = "twin"
                           ) -> Tuple[np.ndarray, np.ndarray]:
        """Frequencies [Hz] and the complex response q_output / x_nom_input (1-based indices)
        of ``model`` ("twin" or "lumped")."""
        if self.bode is None:
            raise ValueError("the twin stage wrote no frequency response")
        name = f"{model}_q{output}_x{input}"
        if f"{name}_dB" not in self.bode:
            raise KeyError(f"no response {name} (columns: {', '.join(self.bode)})")
        mag, phase = self.bode[f"{name}_dB"], self.bode[f"{name}_deg"]
        return self.bode["f_Hz"], 10.0 ** (mag / 20.0) * np.exp(1j * np.deg2rad(phase))


@dataclass(frozen=True, eq=False)
class PeaRecord(StageResult):
    """A PEA record: time t [s], voltage U [V], displacement x [µm]."""

    pea: int = 1
    t: np.ndarray = None  # type: ignore[assignment]
    u: np.ndarray = None  # type: ignore[assignment]
    x: np.ndarray = None  # type: ignore[assignment]


@dataclass(frozen=True, eq=False)
class PeaIdentification(StageResult):
    """Bouc–Wen parameters of one PEA (Appendix B, Algorithm A1; µm and V as Table A1)."""

    pea: int = 1
    #: Parallel RLS and batch estimates, the recommended parameters, errors, compensation.
    estimates: Dict[str, Any] = field(default_factory=dict)
    #: Parameter estimates along the record (Figure A2).
    convergence: Optional[Table] = None
    #: The record against the model.
    loop: Optional[Table] = None
    #: Hysteresis without and with inverse compensation (Eq. 21).
    compensation: Optional[Table] = None

    @property
    def params(self) -> Dict[str, Any]:
        """The recommended Bouc–Wen parameters."""
        return self.estimates.get("recommended_params", {})


@dataclass(frozen=True, eq=False)
class StageIdentification(StageResult):
    """Stage parameters (Section 4.2, Eq. 54–56, Table 4) and, on the twin, its response
    fit."""

    #: The identified parameter file (``params``, ``coupling`` k_c [N/m]).
    params: Optional[Dict[str, Any]] = None
    #: Guess / estimate / truth per parameter (Table 4).
    table: Optional[Records] = None
    #: Estimates along the record.
    convergence: Optional[Table] = None
    #: On the twin: the response fit's parameter file, its table, the measured frequency
    #: response per line and the fit (static gain, modes below Nyquist).
    twin_params: Optional[Dict[str, Any]] = None
    twin_table: Optional[Records] = None
    response: Optional[Records] = None
    response_fit: Optional[Dict[str, Any]] = None


#: Column names of a tracking time series (``track/<trajectory>_<controller>.csv``).
_SERIES = {
    "reference": ("ref1_m", "ref2_m"),
    "measured": ("meas1_m", "meas2_m"),
    "true_output": ("true1_m", "true2_m"),
    "error": ("err1_m", "err2_m"),
    "voltage": ("volt1_V", "volt2_V"),
    "x_nom": ("xnom1_m", "xnom2_m"),
}


@dataclass(frozen=True, eq=False)
class TrackCase:
    """One tracking run (Figures 9–11): every column of its time series, sampled at the
    controller's rate."""

    trajectory: str
    controller: str
    #: Every column by its name (``t_s``, ``ref1_m``, ``err2_m``, ``volt1_V``, ``zhat3``, …).
    series: Table

    @property
    def t(self) -> np.ndarray:
        """Time [s]."""
        return self.series["t_s"]

    def _pair(self, key: str) -> Tuple[np.ndarray, np.ndarray]:
        a, b = _SERIES[key]
        return self.series[a], self.series[b]

    @property
    def reference(self) -> Tuple[np.ndarray, np.ndarray]:
        """Reference of q1, q2 [m]."""
        return self._pair("reference")

    @property
    def measured(self) -> Tuple[np.ndarray, np.ndarray]:
        """Measured q1, q2 [m] (sensor chain, noise)."""
        return self._pair("measured")

    @property
    def true_output(self) -> Tuple[np.ndarray, np.ndarray]:
        """True q1, q2 of the simulated stage [m] (scores, never feeds the controller)."""
        return self._pair("true_output")

    @property
    def error(self) -> Tuple[np.ndarray, np.ndarray]:
        """Tracking error, true output − reference, q1, q2 [m]."""
        return self._pair("error")

    @property
    def voltage(self) -> Tuple[np.ndarray, np.ndarray]:
        """Amplifier voltages U1, U2 [V]."""
        return self._pair("voltage")

    @property
    def x_nom(self) -> Tuple[np.ndarray, np.ndarray]:
        """Commanded nominal strokes x_nom1, x_nom2 [m]."""
        return self._pair("x_nom")


@dataclass(frozen=True, eq=False)
class Tracking(StageResult):
    """The tracking experiment of one folder (``track/`` or ``track/<conditions>/``)."""

    #: The folder's conditions ("" for the defaults, e.g. ``compensation-off``).
    conditions: str = ""
    #: RMS and maximum errors per trajectory and controller [nm, % of range], peak voltage.
    metrics: Records = field(default_factory=list)
    #: Gain, phase and delay margins per controller and loop (on the twin), numbers as
    #: floats: ``gain_margin_dB`` is None for an unstable loop (``unstable`` in the file; with
    #: pandas on the file itself, ``read_csv(..., na_values=["unstable"])``).
    margins: Optional[Records] = None
    #: The Monte-Carlo study of ``track`` (pass per plant and controller).
    montecarlo: Optional[Records] = None
    #: Error against scan frequency.
    scan: Optional[Records] = None
    #: Every run's time series by (trajectory, controller).
    cases: Dict[Tuple[str, str], TrackCase] = field(default_factory=dict)

    def case(self, trajectory: str, controller: str) -> TrackCase:
        """The run of one trajectory and controller."""
        try:
            return self.cases[(trajectory, controller)]
        except KeyError:
            have = ", ".join(f"{t}/{c}" for t, c in self.cases)
            raise KeyError(f"no run {trajectory}/{controller} (runs: {have})") from None


@dataclass(frozen=True, eq=False)
class RunSummary:
    """What ``Run.run()`` did: the summary the CLI prints, the report and the verdict."""

    text: str
    report: Path
    #: What was designed, whether it is safe, which controller to use, what was limited.
    verdict: str

    def __str__(self) -> str:
        return self.text


#: Fields, keys and columns that say where and how long a result was computed, not what:
#: :func:`same` skips them.
_CIRCUMSTANCES = ("folder", "text", "seconds", "seconds_per_iteration", "time_s",
                  "build_seconds", "reference_seconds")


def same(a: Any, b: Any) -> bool:
    """Whether two results hold bitwise the same values: arrays by dtype, shape and bytes,
    floats by their bits (NaN equals NaN of the same bits), dataclasses field by field,
    containers item by item; where and how long it ran (``folder``, ``text``, ``seconds``,
    ``time_s``, …) is not compared."""
    if is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(
            same(getattr(a, f.name), getattr(b, f.name)) for f in fields(a)
            if f.name not in _CIRCUMSTANCES)
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if isinstance(a, float) and isinstance(b, float):
        return struct.pack("<d", a) == struct.pack("<d", b)
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a
                                            if k not in _CIRCUMSTANCES)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return type(a) is type(b) and a == b

