"""Wall time of one campaign on each executor (issue 36).

    .venv/bin/python bench/executors.py [--runs 200] [--seed 17] [--workers 2]

The same campaign (runs, seed) in this process on threads, on a
ProcessPoolExecutor, on a Dask LocalCluster (processes, one thread each)
and on a local Ray cluster, each with `--workers` workers and the default
chunking (about four tasks per worker), and checks that every executor
gives the same rows. Times are from the call to its return; starting and
stopping each cluster is reported apart (`setup_s`). Needs the pinned test
requirements (`scripts/python-env`), which include dask and ray.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import Executor, ProcessPoolExecutor

import bellyflop

TIMING = {"max_replan_ms", "late_replans"}


def rows(c: bellyflop.Campaign) -> list:
    lines = c.runs_csv().splitlines()
    header = lines[0].split(",")
    keep = [i for i, h in enumerate(header) if h not in TIMING]
    return [[line.split(",")[i] for i in keep] for line in lines[1:]]


def timed(fn):
    start = time.perf_counter()
    c = fn()
    return c, time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=17)
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    n, seed, w = a.runs, a.seed, a.workers
    results = []

    c, t = timed(lambda: bellyflop.montecarlo(n, seed=seed, threads=w))
    ref = rows(c)
    results.append(("threads (in process)", t, 0.0, c))

    s0 = time.perf_counter()
    with ProcessPoolExecutor(w) as ex:
        setup = time.perf_counter() - s0
        c, t = timed(lambda: bellyflop.montecarlo(n, seed=seed, executor=ex))
    results.append(("ProcessPoolExecutor", t, setup, c))

    import distributed

    s0 = time.perf_counter()
    with distributed.LocalCluster(
        n_workers=w, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        setup = time.perf_counter() - s0
        c, t = timed(lambda: bellyflop.montecarlo(n, seed=seed, executor=client.get_executor()))
    results.append(("Dask LocalCluster", t, setup, c))

    import ray

    s0 = time.perf_counter()
    ray.init(num_cpus=w, include_dashboard=False, log_to_driver=False, configure_logging=False)

    @ray.remote(num_cpus=1)
    def call(fn, *args):
        return fn(*args)

    class RayExecutor(Executor):
        def __init__(self):
            self._max_workers = int(ray.cluster_resources().get("CPU", 1))

        def submit(self, fn, *args, **kwargs):
            return call.remote(fn, *args).future()

    setup = time.perf_counter() - s0
    try:
        c, t = timed(lambda: bellyflop.montecarlo(n, seed=seed, executor=RayExecutor()))
    finally:
        ray.shutdown()
    results.append(("Ray (local)", t, setup, c))

    print(f"{n} runs, seed {seed}, {w} workers")
    print(f"{'executor':<24}{'wall s':>8}{'per run ms':>12}{'setup s':>9}  same rows")
    for name, t, setup, c in results:
        print(f"{name:<24}{t:>8.2f}{1e3 * t / n:>12.1f}{setup:>9.2f}  {rows(c) == ref and len(c) == n}")


if __name__ == "__main__":
    main()
