"""The Monte-Carlo study of a run (100 plants by default) from its recipe: serially in this
process (its threads), or one task per plant on a Dask LocalCluster of 2 single-threaded
workers, each timed from the recipe to the gathered result (a fresh process: the study's
set-up, the twin and the controllers' design, is in both). Prints wall seconds and the CPU
seconds of every process involved (this one, and on Dask the two workers): on a machine
shared with other work, wall time depends on the load, CPU time much less. Checks the two
modes' results bitwise.

    python3 python/benches/montecarlo.py RUN_FOLDER serial|dask [PLANTS]
"""

import pickle
import resource
import sys
import time

import flexstage as fs
from flexstage import sweeps


def _cpu() -> float:
    """User + system seconds of this process."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    folder, mode = sys.argv[1], sys.argv[2]
    plants = int(sys.argv[3]) if len(sys.argv) > 3 else 100
    recipe = f"{folder}/montecarlo-{plants}.pickle"
    try:
        with open(recipe, "rb") as f:
            study = pickle.load(f)
    except FileNotFoundError:
        with fs.Run.open(folder) as run:
            scenario_json, files = run._n.study_recipe()
        study = fs.MonteCarloStudy(scenario_json, files, ("pi-notch-ff", "robust", "nonrobust",
                                                          "pid-ff"), {"plants": plants})
        with open(recipe, "wb") as f:
            pickle.dump(study, f)
    if mode == "serial":
        t0, c0 = time.perf_counter(), _cpu()
        result = study.run(progress=False)
        seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    else:
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            w0 = client.run(_cpu)
            t0, c0 = time.perf_counter(), _cpu()
            result = sweeps.monte_carlo(study, client)
            seconds, cpu = time.perf_counter() - t0, _cpu() - c0
            w1 = client.run(_cpu)
            cpu += sum(w1[w] - w0[w] for w in w1)
    out = f"{folder}/montecarlo-{plants}-result.pickle"
    try:
        with open(out, "rb") as f:
            print("bitwise equal to the previous mode:", fs.same(pickle.load(f), result))
    except FileNotFoundError:
        pass
    with open(out, "wb") as f:
        pickle.dump(result, f)
    print(f"{mode}: {plants} plants in {seconds:.2f} s wall, {cpu:.2f} s CPU; pass rates",
          {c: result.pass_rate(c) for c in result.controllers})


if __name__ == "__main__":
    main()
