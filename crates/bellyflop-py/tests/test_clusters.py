"""Campaigns on real clusters (issue 36): a local Ray cluster, and a Dask
LocalCluster that loses a worker mid-campaign. Both give the CLI's rows,
every run exactly once."""

from __future__ import annotations

import os
import signal
import threading
import time
from concurrent.futures import Executor

import pytest

import bellyflop
from test_campaign import DASK_RUNS, DASK_SEED, assert_same_campaign, cli_campaign

#: The Ray campaign (BELLYFLOP_RAY_RUNS overrides).
RAY_RUNS = int(os.environ.get("BELLYFLOP_RAY_RUNS", "100"))


class RayExecutor(Executor):
    """The README's adapter: `ObjectRef.future()` is a
    concurrent.futures.Future."""

    def __init__(self, ray, call):
        self._ray = ray
        self._call = call
        self._max_workers = int(ray.cluster_resources().get("CPU", 1))

    def submit(self, fn, *args, **kwargs):
        return self._call.remote(fn, *args).future()


def test_ray_cluster_equals_cli(cli, tmp_path):
    ray = pytest.importorskip("ray")
    text, summary = cli_campaign(cli, tmp_path, RAY_RUNS, DASK_SEED)
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        log_to_driver=False,
        configure_logging=False,
        runtime_env={"env_vars": {"RAY_ENABLE_UV_RUN_RUNTIME_ENV": "0"}},
    )
    try:

        @ray.remote(num_cpus=1)
        def call(fn, *args):
            return fn(*args)

        start = time.perf_counter()
        c = bellyflop.montecarlo(RAY_RUNS, seed=DASK_SEED, executor=RayExecutor(ray, call))
        wall = time.perf_counter() - start
    finally:
        ray.shutdown()
    print(f"Ray, 2 CPUs: {RAY_RUNS} runs in {wall:.2f} s")
    assert len(c) == RAY_RUNS
    assert_same_campaign(c, text, summary)


def test_dask_survives_a_killed_worker(cli, tmp_path):
    """Kill one of two Dask workers (SIGKILL) while the campaign runs. With
    `allowed-failures` 0 the scheduler gives its tasks up (KilledWorker):
    montecarlo re-submits them, and every run comes back exactly once."""
    distributed = pytest.importorskip("distributed")
    import dask

    runs = 60
    text, summary = cli_campaign(cli, tmp_path, runs, DASK_SEED)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        pids = client.run(os.getpid)
        victim_addr, victim = sorted(pids.items())[0]
        box = {}

        dask_executor = client.get_executor()
        attempts = []

        class Counting(Executor):
            """Dask's executor, counting each task's attempt number."""

            _client = client

            def submit(self, fn, *args, **kwargs):
                attempts.append(args[-1])
                return dask_executor.submit(fn, *args, **kwargs)

        def campaign():
            try:
                box["c"] = bellyflop.montecarlo(runs, seed=DASK_SEED, executor=Counting(), chunk=2)
            except BaseException as e:  # noqa: BLE001 - reported below
                box["error"] = e

        t = threading.Thread(target=campaign)
        t.start()
        # Kill the victim once it is flying a chunk.
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if client.processing().get(victim_addr):
                break
            time.sleep(0.02)
        time.sleep(0.2)
        os.kill(victim, signal.SIGKILL)
        t.join(timeout=300)
    assert "error" not in box, box.get("error")
    # The victim's chunk was lost (KilledWorker) and submitted again.
    assert max(attempts) >= 1, attempts
    c = box["c"]
    assert len(c) == runs and list(c["run"]) == list(range(runs))
    assert_same_campaign(c, text, summary)
