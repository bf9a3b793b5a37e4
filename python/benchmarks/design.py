"""The quick preset's design called from Python against the command line, whole processes, in
pairs.

Each measurement is a fresh process designing the quick preset into a fresh folder: either
``flexstage design --force --out FOLDER`` (the workspace's release binary) or a Python
interpreter running ``flexstage.Run(...).design(force=True)`` (interpreter start-up, numpy
and flexstage imports included). Printed per run: wall seconds, CPU seconds (the child's,
through ``wait4``) and the 1-minute load average before it; per pair the Python / CLI
ratios; then medians. Pairs alternate which one runs first, after one warm-up of each.

    python3 python/benchmarks/design.py [--pairs 4] [--cli target/release/flexstage] [--dir DIR]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Dict, List

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PYTHON = """
import sys
import flexstage as fs
with fs.Run(fs.Scenario.preset("quick"), sys.argv[1], replace=True) as run:
    run.design(force=True, progress=False)
"""


def measure(which: str, cli: str, folder: str) -> Dict[str, float]:
    """One whole-process design; wall, CPU and the load before it."""
    shutil.rmtree(folder, ignore_errors=True)
    cmd = ([cli, "design", "--force", "--out", folder] if which == "cli"
           else [sys.executable, "-c", PYTHON, folder])
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"{which} failed: {proc.stderr.read().decode() if proc.stderr else ''}")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "load": load}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", type=int, default=4)
    ap.add_argument("--cli", default=os.path.join(ROOT, "target", "release", "flexstage"))
    ap.add_argument("--dir", default=None, help="where the designs go (default: a temporary "
                    "folder, removed afterwards)")
    args = ap.parse_args()
    base = args.dir or tempfile.mkdtemp(prefix="flexstage-design-bench-")
    folder = os.path.join(base, "quick")
    try:
        for which in ("cli", "python"):
            measure(which, args.cli, folder)  # warm-up: file caches, the binary and library
        runs: Dict[str, List[Dict[str, float]]] = {"cli": [], "python": []}
        walls: List[float] = []
        cpus: List[float] = []
        for k in range(args.pairs):
            order = ("cli", "python") if k % 2 == 0 else ("python", "cli")
            pair = {w: measure(w, args.cli, folder) for w in order}
            for w in order:
                runs[w].append(pair[w])
                f = pair[w]
                print(f"pair {k + 1} {w:6}: {f['wall']:6.2f} s wall {f['cpu']:6.2f} s CPU "
                      f"(load {f['load']:.2f})", flush=True)
            walls.append(pair["python"]["wall"] / pair["cli"]["wall"])
            cpus.append(pair["python"]["cpu"] / pair["cli"]["cpu"])
            print(f"pair {k + 1} python / cli: wall {walls[-1]:.3f}, CPU {cpus[-1]:.3f}",
                  flush=True)
        for w in ("cli", "python"):
            print(f"{w:6}: wall median {statistics.median(r['wall'] for r in runs[w]):.2f} s, "
                  f"CPU median {statistics.median(r['cpu'] for r in runs[w]):.2f} s")
        loads = [r["load"] for w in runs for r in runs[w]]
        print(f"python / cli per pair: wall {', '.join(f'{r:.3f}' for r in walls)} (median "
              f"{statistics.median(walls):.3f}); CPU {', '.join(f'{r:.3f}' for r in cpus)} "
              f"(median {statistics.median(cpus):.3f}); loads {min(loads):.2f}–{max(loads):.2f}")
    finally:
        if args.dir is None:
            shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
