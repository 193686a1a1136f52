"""Python-side overhead of bellyflop.solve against the Rust solve time.

    .venv/bin/python bench/python_overhead.py [--repeats 30]

Per call: `wall` is the time of `bellyflop.solve(...)` seen from Python;
`core` the time spent in Rust inside that call (`Solution._core_ms`: the
solve, the re-propagation for the landing error and the JSON the CLI also
builds); `solve` the method's own `solve_time_ms`. The overhead is
wall - core: argument handling, GIL release and re-acquisition and the
conversion of the result to a Python object. Reading every node array as
numpy (11 arrays) is timed separately. `beyond solve` counts everything
a Python caller waits for beyond the method's own solve time (overhead,
re-propagation, JSON, reading the arrays). Medians over the repeats.
"""

from __future__ import annotations

import argparse
import statistics
import time

import bellyflop

ARRAYS = ["t_s", "x_m", "z_m", "vx_mps", "vz_mps", "theta_rad", "pitch_rate_radps",
          "mass_kg", "delta_rad", "thrust_n", "gimbal_rate_radps"]


def measure(nodes: int, method: str, repeats: int) -> dict:
    scenario = bellyflop.Scenario.paper()
    bellyflop.solve(scenario, nodes=nodes, method=method)  # warm up
    wall, core, solve, arrays = [], [], [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol = bellyflop.solve(scenario, nodes=nodes, method=method)
        t1 = time.perf_counter()
        for name in ARRAYS:
            getattr(sol, name)
        t2 = time.perf_counter()
        wall.append((t1 - t0) * 1e3)
        core.append(sol._core_ms)
        solve.append(sol.solve_time_ms)
        arrays.append((t2 - t1) * 1e3)
    over = [w - c for w, c in zip(wall, core)]
    med = statistics.median
    return {
        "nodes": nodes, "method": method, "wall_ms": med(wall), "core_ms": med(core),
        "solve_ms": med(solve), "overhead_ms": med(over), "arrays_ms": med(arrays),
        "overhead_pct_of_solve": 100 * med(over) / med(solve),
        "overhead_and_arrays_pct_of_solve": 100 * (med(over) + med(arrays)) / med(solve),
        "beyond_solve_pct": 100 * (med(wall) + med(arrays) - med(solve)) / med(solve),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=30)
    a = p.parse_args()
    print(f"{'case':<12}{'wall ms':>9}{'core ms':>9}{'solve ms':>10}{'overhead ms':>13}"
          f"{'arrays ms':>11}{'overhead %':>12}{'+arrays %':>11}{'beyond solve %':>16}")
    for nodes, method in [(20, "direct"), (40, "direct"), (20, "scvx")]:
        r = measure(nodes, method, a.repeats)
        print(f"{method + ' N=' + str(nodes):<12}{r['wall_ms']:>9.3f}{r['core_ms']:>9.3f}"
              f"{r['solve_ms']:>10.3f}{r['overhead_ms']:>13.4f}{r['arrays_ms']:>11.4f}"
              f"{r['overhead_pct_of_solve']:>11.3f}%{r['overhead_and_arrays_pct_of_solve']:>10.3f}%"
              f"{r['beyond_solve_pct']:>15.3f}%")


if __name__ == "__main__":
    main()
