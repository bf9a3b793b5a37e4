"""A run folder and its stages: typed results with numpy arrays, zero-copy views, errors
with the command line's text, opening a folder made earlier."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import flexstage as fs
from flexstage import _native


def test_design_result(run):
    d = run.load_design()
    s = run.scenario
    assert d.density.shape == (s.mesh.nl, s.mesh.nw)
    assert d.density.dtype == np.float64
    assert 0.0 <= d.density.min() and d.density.max() <= 1.0
    assert d.iterations == s.optimization.max_iterations or d.iterations > 0
    # The optimizer enlarges the workspace of the uniform start design (Eq. 4).
    assert d.area > d.area_initial > 0.0
    for poly in (d.workspace_initial, d.workspace_final):
        assert poly.ndim == 2 and poly.shape[1] == 2 and len(poly) >= 3
    assert len(d.history["area_m2"]) == d.iterations
    assert d.extent == (0.0, s.mesh.length, 0.0, s.mesh.width)


def test_density_reaches_numpy_without_a_copy(run):
    d = run.load_design()
    rho = d.density
    assert isinstance(rho.base, _native.Buffer)
    assert rho.__array_interface__["data"][0] == rho.base.address
    assert len(rho.base) == rho.size
    assert not rho.flags.owndata and not rho.flags.writeable and rho.flags.c_contiguous
    with pytest.raises(ValueError):
        rho[0, 0] = 1.0
    # The folder's session shares one value: the same result loaded again is the same buffer.
    assert run.load_design().density.base.address == rho.base.address
    assert np.array(rho).flags.writeable


def test_open_existing_folder_gives_the_same_results(run, tmp_path):
    with pytest.raises(fs.RunFolderError):
        fs.Run.open(run.path)  # this process holds its lock
    copy = tmp_path / "copy"
    shutil.copytree(run.path, copy, ignore=shutil.ignore_patterns("run.lock"))
    with fs.Run.open(copy) as opened:
        assert opened.scenario == run.scenario
        assert fs.same(opened.load_design(), run.load_design())
        assert opened.load_tracking("nosuch") is None


def test_design_is_not_replaced_without_force(run):
    with pytest.raises(fs.RunFolderError, match="force"):
        run.design(progress=False)


def test_bad_option_is_an_option_error(run):
    with pytest.raises(fs.OptionError, match="track.controllers"):
        run.track(controllers=["nosuch"], progress=False)
    with pytest.raises(fs.OptionError, match="unit"):
        run.export(unit="furlong")
    with pytest.raises(fs.OptionError, match="track.montecarlo_plants"):
        run.track(controllers=["pi-notch-ff"], montecarlo_plants=0, progress=False)


def test_analyze_inputs(run):
    a = run.analyze(inputs=[(30e-6, -30e-6)])
    assert a.name.startswith("inputs")
    assert len(next(iter(a.cases.values()))) == 1
    assert run.load_analysis(a.name) is not None
    assert run.load_analysis("nosuch") is None


def test_export_writes_the_outline(run):
    e = run.export(verify=False)
    for kind in ("dxf", "svg", "stl"):
        assert e.files[kind].stat().st_size > 0
    assert e.safe is None


def test_reduce_mode_shapes(run):
    r = run.reduce(progress=False)
    f = r.frequencies
    assert len(f) >= 2 and np.all(np.diff(f) > 0) and f[0] > 0
    assert r.mode_shapes.shape == (len(f), len(r.nodes), 2)
    assert np.all(np.isfinite(r.mode_shapes))
    assert fs.same(run.load_reduction(), r)


def test_pea_identification_from_arrays_equals_from_the_record(run):
    rec = run.simulate_pea(1, seed=7)
    assert rec.t.shape == rec.u.shape == rec.x.shape and len(rec.t) > 100
    from_file = run.identify_pea(1)
    from_arrays = run.identify_pea(1, t=np.array(rec.t), u=np.array(rec.u), x=np.array(rec.x))
    # Bitwise the same estimates; only the named source differs.
    assert from_file.estimates["data"] != from_arrays.estimates["data"] == "<arrays>"
    assert fs.same({**from_file.estimates, "data": ""}, {**from_arrays.estimates, "data": ""})
    # The identified Bouc-Wen parameters of the simulated record are close to Table A1's.
    assert from_file.params
    with pytest.raises(ValueError, match="three arrays"):
        run.identify_pea(1, t=rec.t)


def test_stage_identification_from_arrays_equals_from_the_file(run, tmp_path):
    simulated = run.identify_stage(plant="lumped", duration=0.5, progress=False)
    assert simulated.params and simulated.table and simulated.convergence is not None
    record = tmp_path / "record.csv"
    shutil.copy(run.path / "identify" / "stage" / "record.csv", record)
    from_file = run.identify_stage(record, progress=False)
    # The test reads the CSV (the bindings never do): the arrays a user would have.
    table = np.genfromtxt(record, delimiter=",", names=True)
    arrays = {name: table[name] for name in table.dtype.names}
    from_arrays = run.identify_stage(arrays, progress=False)
    assert fs.same(from_file.params["params"], from_arrays.params["params"])
    assert fs.same(from_file.params["coupling"], from_arrays.params["coupling"])
    assert fs.same(from_file.table, from_arrays.table)
    with pytest.raises(KeyError, match="q2"):
        run.identify_stage({k: v for k, v in arrays.items() if k != "q2"}, progress=False)


def test_tracking_case_and_zero_copy_series(tracked):
    case = tracked.case("circle", "pi-notch-ff")
    t = case.t
    assert t.ndim == 1 and len(t) > 100 and np.all(np.diff(t) > 0)
    for col in [t, *case.error, *case.reference, *case.true_output, *case.series.values()]:
        assert isinstance(col.base, _native.Buffer) and not col.flags.owndata
        assert col.__array_interface__["data"][0] == col.base.address
        assert not col.flags.writeable and len(col) == len(t)
    ref, true = case.reference, case.true_output
    err = case.error
    # The error is scored against the true output (it never feeds the controller).
    np.testing.assert_allclose(err[0], true[0] - ref[0], rtol=0, atol=1e-15)
    assert np.all(np.isfinite(err[0])) and np.abs(err[0]).max() < np.abs(ref[0]).max()
    assert tracked.metrics
    # The Monte-Carlo study ran on the two plants asked for, each with the one controller.
    assert [(r["plant"], r["controller"]) for r in tracked.montecarlo] == [
        (0, "pi-notch-ff"), (1, "pi-notch-ff")]
    with pytest.raises(KeyError, match="circle/pi-notch-ff"):
        tracked.case("circle", "nosuch")


def test_twin_frequency_response(run, tracked):
    # Without the check against the full nonlinear transient (minutes on a shared machine;
    # the quickstart notebook runs it): the response is the same.
    tw = run.twin(validation="off", progress=False)
    f, h = tw.frequency_response(1, 1)
    assert np.iscomplexobj(h) and len(f) == len(h) > 10
    f2, h2 = tw.frequency_response(1, 1, "lumped")
    # At the lowest frequency twin and lumped model agree on the static gain within 10 %.
    assert abs(abs(h[0]) / abs(h2[0]) - 1.0) < 0.1
    with pytest.raises(KeyError):
        tw.frequency_response(3, 1)


def test_margins_are_floats_and_an_unstable_loop_has_none(run, tracked, tmp_path):
    """Goal: ``margins.csv`` reaches Python with every margin a float (pandas makes float
    columns of it), the gain margin too, although the file writes an unstable loop's gain
    margin as the word ``unstable``: that one reads as None."""
    rows = tracked.margins
    assert rows and all(isinstance(r["gain_margin_dB"], float) for r in rows)
    assert all(isinstance(r["phase_margin_deg"], float) for r in rows)
    copy = tmp_path / "unstable"
    shutil.copytree(run.path, copy, ignore=shutil.ignore_patterns("run.lock"))  # held by run
    margins = copy / "track" / "margins.csv"
    lines = margins.read_text().splitlines(keepends=True)
    header = lines[0].rstrip("\n").split(",")
    col = header.index("gain_margin_dB")
    cells = lines[1].rstrip("\n").split(",")
    kept = float(lines[2].rstrip("\n").split(",")[col])
    cells[col] = "unstable"
    lines[1] = ",".join(cells) + "\n"
    margins.write_text("".join(lines))
    with fs.Run.open(copy) as again:
        read = again.load_tracking().margins
    assert read[0]["gain_margin_dB"] is None
    assert read[1]["gain_margin_dB"] == kept and isinstance(read[1]["gain_margin_dB"], float)
