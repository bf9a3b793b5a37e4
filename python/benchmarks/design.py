"""The quick preset's design from Python, in a fresh folder (whole-process timing against
`flexstage design --force` on the same preset: docs/TESTING.md)."""

import sys

import flexstage as fs

folder = sys.argv[1] if len(sys.argv) > 1 else "runs/bench-design"
with fs.Run(fs.Scenario.preset("quick"), folder, replace=True) as run:
    run.design(force=True, progress=False)
