"""The Monte-Carlo study of a run (100 plants × 4 controllers by default) from its recipe,
serially (``study.run()``: this process's threads, rayon on every core) against a Dask
``LocalCluster`` of 2 single-threaded worker processes on the same cores
(``flexstage.sweeps.monte_carlo``), in pairs.

Each measurement is a fresh process that loads the pickled recipe, imports flexstage and
(Dask) starts the cluster and imports flexstage in its workers, then times from the recipe
to the gathered result: the study's set-up (twin, controllers designed on it) is inside the
timing in both modes, once in the serial process and once in each worker. Then the same
study again in the same process and cluster ("warm": set up already everywhere), which is
what the plants alone cost. Printed: wall seconds, the CPU seconds of every process involved
(the measuring one and its children: the workers), and the 1-minute load average before and
after each run (others share the machine: wall times depend on it, CPU times much less).
Pairs alternate which mode runs first. Every Dask result is checked bitwise against the
serial one.

    python3 python/benchmarks/montecarlo.py RUN_FOLDER [--plants 100] [--pairs 5] [--per-worker N]
        [--no-warm] [--no-warmup]

``--per-worker``: batches of plants per worker thread (``sweeps.monte_carlo``'s; default a
task per plant). ``--no-warm``: time each study once (no second, warm run in the same
processes). ``--no-warmup``: no serial run before the pairs (the first pair's serial run,
which runs first, gives the reference result). Each Dask figure also splits the CPU into
the measuring process (client and scheduler) and its children (the worker processes and
their nannies).

``RUN_FOLDER`` holds a finished design (``flexstage design --out RUN_FOLDER``); the recipe is
written beside it as ``montecarlo-<plants>.pickle`` on first use.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import statistics
import subprocess
import sys
import time
from typing import Any, Dict, List, Optional

CONTROLLERS = ("pi-notch-ff", "robust", "nonrobust", "pid-ff")


def _cpu_split() -> List[float]:
    """User + system seconds of this process and of its live children (recursively)."""
    import psutil

    me = psutil.Process()
    split = [0.0, 0.0]
    for k, p in enumerate([me, *me.children(recursive=True)]):
        try:
            t = p.cpu_times()
        except psutil.NoSuchProcess:
            continue
        split[min(k, 1)] += t.user + t.system
    return split


def _cpu_tree() -> float:
    return sum(_cpu_split())


def _import_flexstage() -> str:
    import flexstage

    return flexstage.__file__


def child(recipe: str, mode: str, out: str, per_worker: Optional[int], warm: bool) -> None:
    """One measurement in this (fresh) process, its figures as JSON on the last line: the
    study from its recipe (``wall``, ``cpu``: the set-up inside), then the same study again
    (``warm_wall``, ``warm_cpu``: set up already, in this process or in every worker)."""
    import flexstage as fs
    from flexstage import sweeps

    with open(recipe, "rb") as f:
        study = pickle.load(f)
    if mode == "serial":
        def once() -> Any:
            return study.run(progress=False)

        figures, result = _timed(once, warm)
    else:
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            client.run(_import_flexstage)

            def once() -> Any:
                return sweeps.monte_carlo(study, client, per_worker=per_worker)

            figures, result = _timed(once, warm)
    equal = None
    if os.path.exists(out):
        with open(out, "rb") as f:
            equal = fs.same(pickle.load(f), result)
    if mode == "serial":
        with open(out, "wb") as f:
            pickle.dump(result, f)
    figures.update(mode=mode, equal_to_serial=equal,
                   pass_rates={c: result.pass_rate(c) for c in result.controllers})
    print(json.dumps(figures))


def _timed(once: Any, warm: bool) -> Any:
    """Wall and CPU seconds of ``once()`` cold and (``warm``) warm, and the (identical)
    result; the cold CPU also split into this process and its children."""
    c0, t0 = _cpu_split(), time.perf_counter()
    result = once()
    seconds, c1 = time.perf_counter() - t0, _cpu_split()
    cpu, own = sum(c1) - sum(c0), c1[0] - c0[0]
    if not warm:
        return {"wall": seconds, "cpu": cpu, "cpu_own": own, "warm_wall": None,
                "warm_cpu": None}, result
    c0, t0 = _cpu_tree(), time.perf_counter()
    again = once()
    warm, warm_cpu = time.perf_counter() - t0, _cpu_tree() - c0
    import flexstage as fs

    if not fs.same(result, again):
        sys.exit("the second run of the study differs from the first")
    return {"wall": seconds, "cpu": cpu, "cpu_own": own, "warm_wall": warm,
            "warm_cpu": warm_cpu}, result


def recipe_of(folder: str, plants: int) -> str:
    """The pickled recipe of the study of ``folder`` (written on first use)."""
    import flexstage as fs

    path = os.path.join(folder, f"montecarlo-{plants}.pickle")
    if not os.path.exists(path):
        with fs.Run.open(folder) as run:
            scenario_json, files = run._n.study_recipe()
        study = fs.MonteCarloStudy(scenario_json, files, CONTROLLERS, {"plants": plants})
        with open(path, "wb") as f:
            pickle.dump(study, f)
    return path


def measure(recipe: str, mode: str, out: str, per_worker: Optional[int],
            warm: bool) -> Dict[str, Any]:
    load = os.getloadavg()[0]
    extra = ([] if per_worker is None else ["--per-worker", str(per_worker)]) + \
        ([] if warm else ["--no-warm"])
    done = subprocess.run([sys.executable, __file__, os.path.dirname(recipe), "--child", mode,
                           recipe, out, *extra], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{mode} failed:\n{done.stderr}")
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    figures["load"], figures["load_after"] = load, os.getloadavg()[0]
    return figures


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder")
    ap.add_argument("--plants", type=int, default=100)
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--per-worker", type=int, default=None)
    ap.add_argument("--no-warm", action="store_true")
    ap.add_argument("--no-warmup", action="store_true")
    ap.add_argument("--child", nargs=3, metavar=("MODE", "RECIPE", "OUT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        mode, recipe, out = args.child
        child(recipe, mode, out, args.per_worker, not args.no_warm)
        return
    recipe = recipe_of(args.folder, args.plants)
    out = os.path.join(args.folder, f"montecarlo-{args.plants}-serial.pickle")
    if os.path.exists(out):
        os.remove(out)
    warm = not args.no_warm
    if not args.no_warmup:  # the serial reference result, the file caches
        measure(recipe, "serial", out, args.per_worker, warm)
    rows: List[Dict[str, Any]] = []
    for k in range(args.pairs):
        order = ("serial", "dask") if k % 2 == 0 else ("dask", "serial")
        pair = {m: measure(recipe, m, out, args.per_worker, warm) for m in order}
        if not pair["dask"]["equal_to_serial"]:
            sys.exit("the Dask result differs from the serial one")
        for m in order:
            f = pair[m]
            rows.append(f)
            again = (f"; warm {f['warm_wall']:6.2f} s wall {f['warm_cpu']:6.2f} s CPU"
                     if warm else "")
            print(f"pair {k + 1} {m:6}: {f['wall']:6.2f} s wall {f['cpu']:6.2f} s CPU "
                  f"(this process {f['cpu_own']:.2f} s){again} "
                  f"(load {f['load']:.2f} → {f['load_after']:.2f})", flush=True)
        d, s_ = pair["dask"], pair["serial"]
        again = f"; warm wall {d['warm_wall'] / s_['warm_wall']:.3f}" if warm else ""
        print(f"pair {k + 1} dask / serial wall {d['wall'] / s_['wall']:.3f}, CPU "
              f"{d['cpu'] / s_['cpu']:.3f}{again}", flush=True)
    pairs = [(rows[2 * k], rows[2 * k + 1]) for k in range(args.pairs)]
    by = [{r["mode"]: r for r in p} for p in pairs]
    for key in ("wall", "cpu") + (("warm_wall",) if warm else ()):
        ratios = [b["dask"][key] / b["serial"][key] for b in by]
        print(f"dask / serial {key} per pair: {', '.join(f'{r:.3f}' for r in ratios)}; "
              f"median {statistics.median(ratios):.3f}")
    for m in ("serial", "dask"):
        walls = [r["wall"] for r in rows if r["mode"] == m]
        cpus = [r["cpu"] for r in rows if r["mode"] == m]
        print(f"{m:6}: wall median {statistics.median(walls):.2f} s "
              f"[{min(walls):.2f}, {max(walls):.2f}], CPU median {statistics.median(cpus):.2f} s")
    print(f"loads {min(r['load'] for r in rows):.2f}–{max(r['load_after'] for r in rows):.2f}; "
          "results bitwise equal: yes")

if __name__ == "__main__":
    main()
