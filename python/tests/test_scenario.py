"""Scenarios: presets, TOML, attribute edits validated with the command line's messages."""

from __future__ import annotations

import pickle
import subprocess

import pytest

import flexstage as fs


def test_presets_are_the_cli_presets():
    assert fs.DEFAULT_PRESET == "quick"
    assert {"quick", "paper"} <= set(fs.PRESETS)
    s = fs.Scenario.preset("quick")
    assert s.name == "quick"
    assert (s.mesh.nl, s.mesh.nw) == (48, 24)


def test_unknown_preset_names_the_presets():
    with pytest.raises(fs.FlexstageError, match="nosuch.*quick, paper"):
        fs.Scenario.preset("nosuch")


def test_attribute_edit_is_validated_and_a_refused_edit_changes_nothing():
    s = fs.Scenario.preset("quick")
    s.mesh.nl = 40
    assert s.mesh.nl == 40
    with pytest.raises(fs.ScenarioError, match="mesh.nl") as e:
        s.mesh.nl = 0
    assert "0" in str(e.value)
    assert s.mesh.nl == 40
    with pytest.raises(fs.ScenarioError):
        s.trajectories[0].frequency = -1.0
    assert s.trajectories[0].frequency > 0


def test_update_sets_fields_together_by_dotted_path():
    s = fs.Scenario.preset("quick")
    s.update({"mesh.nl": 40, "mesh.nw": 20})
    assert (s.get("mesh.nl"), s.get("mesh.nw")) == (40, 20)
    before = s.to_dict()
    with pytest.raises(fs.ScenarioError):
        s.update({"mesh.nl": 44, "mesh.nw": -1})
    assert s.to_dict() == before


def test_toml_round_trip_and_pickle():
    s = fs.Scenario.preset("paper")
    s.optimization.max_iterations = 17
    t = fs.Scenario.from_toml(s.to_toml(commented=True))
    assert t == s
    assert pickle.loads(pickle.dumps(s)) == s
    c = s.copy()
    c.optimization.max_iterations = 18
    assert s.optimization.max_iterations == 17


def test_invalid_file_has_the_cli_message(tmp_path, cli):
    path = tmp_path / "bad.toml"
    text = fs.Scenario.preset("quick").to_toml().replace("nl = 48", "nl = 0", 1)
    assert text != fs.Scenario.preset("quick").to_toml()
    path.write_text(text)
    with pytest.raises(fs.ScenarioError) as e:
        fs.Scenario.load(path)
    out = subprocess.run([str(cli), "check", str(path)], capture_output=True, text=True)
    assert out.returncode != 0
    assert f"error: {e.value}" in out.stderr


def test_field_docs_give_units():
    doc = fs.Scenario.doc("mesh.length")
    assert doc and "m" in doc
    assert fs.Scenario.doc("no.such.field") is None
    assert "nl" in dir(fs.Scenario.preset("quick").mesh)


def test_unknown_field_is_refused():
    s = fs.Scenario.preset("quick")
    with pytest.raises(Exception, match="nosuch"):
        s.mesh.nosuch = 1
    with pytest.raises(Exception, match="nosuch"):
        _ = s.mesh.nosuch
