"""bellyflop from Python: solve the paper's case, fly a dispersed landing,
and run a 200-run Monte Carlo campaign on a local Dask cluster.

    pip install ./crates/bellyflop-py matplotlib "dask[distributed]"
    python examples/python/landing.py [--runs 200] [--seed 1] [--out plots]

Writes paths.png (the optimal x-z path of the paper's case, the plan and the
flown path of a dispersed landing) and touchdown.png (the campaign's
touchdown errors) into --out.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import bellyflop  # noqa: E402


def plot_paths(out: Path, seed: int) -> None:
    paper = bellyflop.solve()
    print(f"paper's case: {paper.status}, t_f {paper.tf_s:.4f} s, "
          f"final mass {paper.final_mass_kg:.1f} kg, {paper.iterations} iterations, "
          f"{paper.solve_time_ms:.1f} ms, lands {paper.landing_error['position_m']:.2f} m off")

    # A dispersed initial state: 150 m downrange, faster and lighter.
    d = bellyflop.Scenario.paper().to_dict()
    d["initial"].update(x_m=d["initial"]["x_m"] + 150.0, vz_mps=d["initial"]["vz_mps"] - 5.0,
                        mass_kg=d["initial"]["mass_kg"] - 3000.0)
    dispersed = bellyflop.solve(bellyflop.Scenario.from_dict(d), nodes=40)
    print(f"dispersed state: {dispersed.status}, t_f {dispersed.tf_s:.4f} s, "
          f"final mass {dispersed.final_mass_kg:.1f} kg")

    # One closed-loop landing of the campaign (run 0): plan, re-plans, flight.
    flight = bellyflop.sim(seed=seed, run=0)
    print(f"closed loop run 0: {flight.outcome_name}, fuel {flight.fuel_kg:.1f} kg, "
          f"{len(flight.replans)} re-plans")

    fig, ax = plt.subplots(figsize=(6, 7))
    ax.plot(paper.x_m, paper.z_m, "o-", ms=3, label="paper's case (N = 20)")
    ax.plot(dispersed.x_m, dispersed.z_m, "s-", ms=3, label="dispersed state (N = 40)")
    ax.plot(flight.trace["x_m"], flight.trace["z_m"], "-", lw=1,
            label=f"closed loop, seed {seed} run 0 ({flight.outcome_name})")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("Centre-of-mass paths")
    fig.tight_layout()
    fig.savefig(out / "paths.png", dpi=120)


def campaign(out: Path, runs: int, seed: int) -> None:
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        c = bellyflop.montecarlo(runs, seed=seed, executor=client.get_executor())
    s = c.summary
    print(f"campaign: {s['runs']} runs in {s['wall_time_s']:.1f} s, {s['in_spec']} within spec, "
          f"outcomes {s['outcomes']}")
    print(f"  touchdown position p50/p99 {s['touchdown_position_m']['p50']:.3f} / "
          f"{s['touchdown_position_m']['p99']:.3f} m")

    touched = np.isin(c["outcome"], ["landed", "hard_landing", "crash"])
    fig, ax = plt.subplots(figsize=(6, 5))
    for outcome in np.unique(c["outcome"]):
        k = c["outcome"] == outcome
        ax.scatter(c["x_error_m"][k], c["speed_mps"][k], s=10, label=f"{outcome} ({k.sum()})")
    spec = s["spec"]
    ax.axvline(-spec["position_m"], color="grey", ls="--", lw=0.8)
    ax.axvline(spec["position_m"], color="grey", ls="--", lw=0.8)
    ax.axhline(spec["speed_mps"], color="grey", ls="--", lw=0.8)
    ax.set_xlabel("touchdown position error x [m]")
    ax.set_ylabel("touchdown speed [m/s]")
    ax.set_title(f"{runs} dispersed landings, seed {seed} ({int(touched.sum())} touchdowns)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "touchdown.png", dpi=120)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("plots"))
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    plot_paths(a.out, a.seed)
    campaign(a.out, a.runs, a.seed)
    print(f"wrote {a.out / 'paths.png'}, {a.out / 'touchdown.png'}")


if __name__ == "__main__":
    main()
