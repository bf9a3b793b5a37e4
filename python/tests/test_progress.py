"""Long calls: progress reported from the calling thread, Ctrl-C stops a design cleanly."""

from __future__ import annotations

import os
import signal
import threading

import pytest

import flexstage as fs
from flexstage.progress import LineReporter, reporter

from conftest import quick


class Recorder:
    def __init__(self, fail_at: int = -1):
        self.calls = []
        self.fail_at = fail_at

    def start(self, task, total):
        self.calls.append(("start", task, total))

    def update(self, position, message):
        self.calls.append(("update", position, message))
        if 0 <= self.fail_at <= position:
            raise RuntimeError("reporter failed")

    def note(self, line):
        self.calls.append(("note", line))

    def finish(self):
        self.calls.append(("finish",))


def test_reporter_choice():
    assert reporter(False) is None and reporter(None) is None
    r = Recorder()
    assert reporter(r) is r
    assert type(reporter(True)).__name__ in ("TqdmReporter", "LineReporter")
    LineReporter().finish()


def test_design_reports_its_iterations(tmp_path):
    rec = Recorder()
    with fs.Run(quick(4), tmp_path / "q") as run:
        d = run.design(progress=rec)
    kinds = [c[0] for c in rec.calls]
    assert kinds[0] in ("start", "note") and "start" in kinds and "finish" in kinds
    positions = [c[1] for c in rec.calls if c[0] == "update"]
    assert positions == sorted(positions) and positions[-1] <= d.iterations
    assert d.iterations in (4, 5)  # max_iterations, and the final analysis


def test_a_failing_reporter_stops_the_call(tmp_path):
    with fs.Run(quick(200), tmp_path / "q") as run:
        with pytest.raises((RuntimeError, KeyboardInterrupt)):
            run.design(progress=Recorder(fail_at=1))
        assert run.load_design() is None


def test_ctrl_c_stops_a_design_and_leaves_its_checkpoint(tmp_path):
    with fs.Run(quick(400), tmp_path / "q") as run:
        timer = threading.Timer(1.5, os.kill, (os.getpid(), signal.SIGINT))
        timer.start()
        try:
            with pytest.raises(KeyboardInterrupt, match="design"):
                run.design(progress=False)
        finally:
            timer.cancel()
        assert run.load_design() is None
        # Interrupted, not finished: the run folder asks for --resume or --force.
        with pytest.raises(fs.RunFolderError, match="resume"):
            run.design(progress=False)
        d = run.design(resume=True, max_iterations=3, progress=False)
        assert d.iterations >= 1
