"""Sweeps on a Dask cluster: one task per design or per plant, results gathered as
the same objects as the serial calls, bitwise, whatever the number of workers.

* :func:`designs`: a list of scenarios (e.g. the resonance bounds of a workspace–resonance
  front), one design each. A design is deterministic (parallel sums in fixed chunks, in
  order), so a worker computes the same bits as this process.
* :func:`monte_carlo`: the Monte-Carlo study of a run (:class:`flexstage.MonteCarloStudy`),
  one task per plant by default: a plant costs seconds (measured in its rig, every
  controller designed from the measurement, then run) and plants differ several-fold in
  cost, so the finest tasks keep the workers evenly loaded to the end, and a task's round
  trip (milliseconds) is small beside a plant; ``per_worker`` batches consecutive plants
  instead. A plant runs on the worker thread that computes it (measured: its CPU time is
  that thread's; it starts no threads), so a worker process uses as many cores as it has
  threads. The study's recipe is
  sent to every worker once (``client.scatter(..., broadcast=True)``); each worker sets the
  study up once (the nominal twin) and keeps it. Plant ``i`` depends on the seed and ``i``
  alone, so neither the tasks nor the number of workers change a bit.

Give a ``dask.distributed.Client`` you already run; without one (``client=None``) the same
tasks run here, one after the other. Dask is needed only when a client is given.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .results import Design
from .run import Run
from .scenario import Scenario
from .study import MonteCarlo, MonteCarloStudy, PlantResult


def design_task(scenario: Scenario, folder: Optional[str] = None,
                options: Optional[Dict[str, Any]] = None) -> Design:
    """One design of a sweep: in ``folder`` (replacing an earlier design there), or in a
    temporary folder removed afterwards. Runs in a Dask worker or here."""
    tmp = None
    if folder is None:
        tmp = tempfile.mkdtemp(prefix="flexstage-sweep-")
        folder = os.path.join(tmp, scenario.name)
    try:
        with Run(scenario, folder, replace=True) as run:
            return run.design(force=True, progress=False, **(options or {}))
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def designs(scenarios: Sequence[Scenario], client: Any = None, *,
            root: Optional[Any] = None, **options: Any) -> List[Design]:
    """Designs every scenario, one task each on ``client`` (else here, in order); results in
    the scenarios' order. ``root``: keep each design in ``root/<scenario name>`` (names must
    then differ; on a cluster, a folder every worker can write), else temporary folders.
    ``options`` go to :meth:`flexstage.Run.design` (``max_iterations``, …)."""
    folders: List[Optional[str]] = [None] * len(scenarios)
    if root is not None:
        names = [s.name for s in scenarios]
        if len(set(names)) != len(names):
            raise ValueError(f"scenario names must differ to share root {root}: {names}")
        folders = [str(Path(root) / n) for n in names]
    if client is None:
        return [design_task(s, f, options) for s, f in zip(scenarios, folders)]
    futures = client.map(design_task, list(scenarios), folders, options=options or None,
                         pure=False)
    return client.gather(futures)


#: The heap's trim and mmap thresholds while plants run [bytes] (glibc's own grow up to
#: 64 and 32 MiB; 32 MiB is the largest mmap threshold glibc takes).
TRIM_THRESHOLD = 32 << 20


def keep_freed_heap(threshold: int = TRIM_THRESHOLD) -> bool:
    """Raises glibc's heap trim and mmap thresholds of this process to ``threshold`` when
    the environment set a smaller trim threshold, as Dask's nanny does for its workers
    (``MALLOC_TRIM_THRESHOLD_=65536``, ``distributed.nanny.pre-spawn-environ``). That
    setting also fixes the mmap threshold at 128 KiB (glibc stops adapting it), so every
    buffer of 128 KiB or more is mapped and unmapped each time, and its pages come back as
    page faults: a plant, which allocates and frees its buffers thousands of times, took
    100 × the minor faults and +8 % CPU (measured). Returns whether it changed them (not on
    other C libraries, nor without the variable)."""
    import ctypes

    try:
        current = int(os.environ.get("MALLOC_TRIM_THRESHOLD_", ""))
    except ValueError:
        return False
    if current >= threshold:
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (AttributeError, OSError):
        return False
    m_trim_threshold, m_mmap_threshold = -1, -3
    return bool(mallopt(m_trim_threshold, threshold)) and bool(mallopt(m_mmap_threshold,
                                                                        threshold))


def plants_task(first: int, stop: int, study: MonteCarloStudy) -> List[PlantResult]:
    """Plants ``first`` to ``stop - 1`` of ``study`` (set up once per process), the heap
    kept (:func:`keep_freed_heap`). Runs in a Dask worker or here."""
    keep_freed_heap()
    return [study.plant(i) for i in range(first, stop)]


def batches(plants: int, workers: int, per_worker: int = 16) -> List[Tuple[int, int]]:
    """``plants`` cut into consecutive ``(first, stop)`` batches, about ``per_worker`` for
    each of ``workers`` worker threads (at least one plant each): few enough that the
    cluster's per-task cost stays small beside the plants, enough that a worker that set up
    late still gets its share."""
    if plants < 0 or workers < 1 or per_worker < 1:
        raise ValueError(f"batches of {plants} plants over {workers} workers, {per_worker} "
                         "per worker: plants must be ≥ 0, workers and per_worker ≥ 1")
    size = max(1, -(-plants // (workers * per_worker)))
    return [(i, min(i + size, plants)) for i in range(0, plants, size)]


def monte_carlo(study: MonteCarloStudy, client: Any = None, *,
                per_worker: Optional[int] = None) -> MonteCarlo:
    """The study on ``client``, one task per plant (``per_worker``: that many batches of
    consecutive plants per worker thread instead), else here, one plant after the other
    (:meth:`MonteCarloStudy.run` uses this process's threads instead). The result is the
    same, bitwise, whatever the tasks and workers."""
    n = study.plants
    if client is None:
        plants = plants_task(0, n, study)
    else:
        if per_worker is None:
            cuts = [(i, i + 1) for i in range(n)]
        else:
            workers = max(1, sum(client.nthreads().values()))  # task slots
            cuts = batches(n, workers, per_worker)
        [shared] = client.scatter([study], broadcast=True)
        futures = client.map(plants_task, [a for a, _ in cuts], [b for _, b in cuts],
                             study=shared, pure=False)
        plants = [p for batch in client.gather(futures) for p in batch]  # in plant order
    return MonteCarlo(controllers=study.controllers, plants=plants)
