"""Scenarios: built-in presets, TOML files, and edits by attribute.

A :class:`Scenario` is always valid. Every edit (``s.mesh.nl = 40``) is checked at once by
the same validation as ``flexstage check``, with the same messages; a refused edit raises
:class:`flexstage.ScenarioError` and changes nothing. Fields that must change together are
set in one call with :meth:`Scenario.update`. Units are SI, except the Bouc–Wen parameters
(µm and V, as Table A1 of the paper gives them); ``help(s.mesh)`` and
``Scenario.doc("mesh.nl")`` give each field's meaning, unit and source.
"""

from __future__ import annotations

import re
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Union

from . import _native

Key = Union[str, int]

_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]")


def parse_path(path: str) -> List[Key]:
    """``"trajectories[0].frequency"`` → ``["trajectories", 0, "frequency"]``."""
    keys: List[Key] = []
    for part in path.split("."):
        for m in _STEP.finditer(part):
            keys.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
    if not keys:
        raise KeyError(f"empty field path {path!r}")
    return keys


def dotted(path: Sequence[Key]) -> str:
    out = ""
    for k in path:
        if isinstance(k, int):
            out += f"[{k}]"
        else:
            out += ("." if out else "") + k
    return out


def plain(value: Any) -> Any:
    """Numpy scalars and arrays as Python numbers and lists (what TOML holds)."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    return value


class Group:
    """A table of the scenario (``s.mesh``, ``s.trajectories[0]``): its fields read and set as
    attributes; setting validates the whole scenario."""

    __slots__ = ("_scenario", "_path")

    def __init__(self, scenario: "Scenario", path: List[Key]):
        object.__setattr__(self, "_scenario", scenario)
        object.__setattr__(self, "_path", path)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        return self._scenario._at(self._path + [name])

    def __setattr__(self, name: str, value: Any) -> None:
        self._scenario._set(self._path + [name], value)

    def __dir__(self) -> List[str]:
        return self._scenario._native.fields(self._path)

    def to_dict(self) -> Dict[str, Any]:
        """The table as plain data."""
        return self._scenario._native.get(self._path)

    @property
    def __doc__(self) -> str:  # type: ignore[override]
        return self._scenario._doc_of(self._path)

    def __repr__(self) -> str:
        return f"<{dotted(self._path)} {self.to_dict()!r}>"

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Group):
            return self.to_dict() == other.to_dict()
        return self.to_dict() == other


class Tables(Sequence[Group]):
    """An array of tables (``s.trajectories``, ``s.supports``): index it for a :class:`Group`;
    assign a list of dicts to the attribute to replace it."""

    __slots__ = ("_scenario", "_path")

    def __init__(self, scenario: "Scenario", path: List[Key]):
        self._scenario = scenario
        self._path = path

    def __len__(self) -> int:
        return self._scenario._native.length(self._path)

    def __getitem__(self, i):  # type: ignore[override]
        n = len(self)
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(n))]
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"{dotted(self._path)} has {n} entries, no index {i}")
        return Group(self._scenario, self._path + [i])

    def __iter__(self) -> Iterator[Group]:
        return (self[i] for i in range(len(self)))

    def to_list(self) -> List[Dict[str, Any]]:
        """The tables as plain data."""
        return self._scenario._native.get(self._path)

    def __repr__(self) -> str:
        return f"<{dotted(self._path)} {self.to_list()!r}>"


class Scenario:
    """A flexstage scenario (the TOML input deck), always valid.

    Make one with :meth:`preset`, :meth:`from_toml` or :meth:`load`; read and set its fields
    as attributes (``s.mesh.nl``, ``s.trajectories[0].frequency``); :meth:`to_toml` and
    :meth:`save` write it as ``flexstage init`` does.
    """

    __slots__ = ("_native",)

    def __init__(self, native: Optional[_native.Scenario] = None):
        object.__setattr__(
            self, "_native", native if native is not None else _native.Scenario.preset("quick")
        )

    # -- construction -------------------------------------------------------------------
    @staticmethod
    def preset(name: str = "quick") -> "Scenario":
        """A built-in scenario: ``"quick"`` (48 × 24 mesh, seconds), ``"paper"`` (the paper's
        Tables 1, 3, 4, A1: 120 × 60) or ``"fine"`` (240 × 120)."""
        return Scenario(_native.Scenario.preset(name))

    @staticmethod
    def from_toml(text: str, origin: str = "<string>") -> "Scenario":
        """Parses and validates TOML text (``origin`` names it in messages)."""
        return Scenario(_native.Scenario.from_toml(text, origin))

    @staticmethod
    def load(path: Any) -> "Scenario":
        """Reads, parses and validates a scenario file."""
        return Scenario(_native.Scenario.load(str(path)))

    # -- output -------------------------------------------------------------------------
    def to_toml(self, commented: bool = False) -> str:
        """The scenario as TOML; ``commented``: one comment per field (meaning, unit,
        source)."""
        return self._native.to_toml(commented)

    def save(self, path: Any) -> None:
        """Writes the commented TOML to ``path`` (atomically)."""
        self._native.save(str(path))

    def to_dict(self) -> Dict[str, Any]:
        """The whole scenario as plain data."""
        return self._native.get([])

    # -- fields -------------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The scenario's name; its default run folder is ``runs/<name>``."""
        return self._native.name

    def _at(self, path: List[Key]) -> Any:
        kind = self._native.kind(path)
        if kind == "table":
            return Group(self, path)
        if kind == "tables":
            return Tables(self, path)
        value = self._native.get(path)
        return tuple(value) if isinstance(value, list) else value

    def _set(self, path: List[Key], value: Any) -> None:
        self._native.set_many([(path, plain(value))])

    def _doc_of(self, path: Sequence[Key]) -> str:
        key = ".".join(k for k in path if isinstance(k, str))
        lines = [self.doc(key) or dotted(path)]
        for field in self._native.fields(list(path)):
            doc = self.doc(f"{key}.{field}" if key else field)
            if doc:
                lines.append(f"  {field}: {doc}")
        return "\n".join(lines)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        return self._at([name])

    def __setattr__(self, name: str, value: Any) -> None:
        self._set([name], value)

    def __dir__(self) -> List[str]:
        methods = {"copy", "doc", "from_toml", "get", "load", "preset", "save", "to_dict",
                   "to_toml", "update", "validate"}
        return sorted(set(self._native.fields([])) | methods)

    def get(self, path: str) -> Any:
        """The value at a dotted path (``"mesh.nl"``, ``"trajectories[1].frequency"``)."""
        return self._native.get(parse_path(path))

    def update(self, fields: Mapping[str, Any]) -> "Scenario":
        """Sets several fields by dotted path in one validated edit (for fields that must
        change together); a refused edit changes nothing. Returns the scenario."""
        self._native.set_many([(parse_path(k), plain(v)) for k, v in fields.items()])
        return self

    def copy(self) -> "Scenario":
        """An independent copy."""
        return Scenario(self._native.__copy__())

    def validate(self) -> None:
        """Checks every group and the relations between them (a scenario always passes: it
        is validated when made and at every edit)."""
        self._native.validate()

    @staticmethod
    def doc(path: str) -> Optional[str]:
        """The documentation of a field by its path without indices (``"mesh.nl"``,
        ``"trajectories.frequency"``): meaning, unit and source."""
        return _native.Scenario.field_doc(path)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scenario) and self._native == other._native

    __hash__ = None  # type: ignore[assignment]  # mutable

    def __reduce__(self):
        return (_from_json, (self._native.to_json(),))

    def __repr__(self) -> str:
        return f"<Scenario {self.name!r}: mesh {self.mesh.nl} x {self.mesh.nw}>"


def _from_json(text: str) -> Scenario:
    return Scenario(_native.Scenario.from_json(text))
