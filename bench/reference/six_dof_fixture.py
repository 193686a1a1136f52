#!/usr/bin/env python3
"""Writes the fixtures of the Rust 6-DoF tests (crates/bellyflop/tests/six_dof.rs)
from nlp_6dof.py, which is written apart from the Rust model:

* tests/data/six_dof_rhs.json: the 6-DoF right-hand side at seeded states
  out of the plane (the paper's vehicle; a wind along x and across);
* tests/data/six_dof_answers.json: IPOPT's answers of the 6-DoF
  transcription at N = 20 for the first three seeded 3-D states of
  `nlp_6dof.py --states` (seed 38), which the Rust transcription
  (collocation::residuals) must find satisfied, and their controls flown
  by reintegrate6 (scipy's DOP853), which the Rust flight
  (verify::flight) must reproduce.

    bench/reference/.venv/bin/python bench/reference/six_dof_fixture.py
"""
import dataclasses
import json
import math
import random
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

import nlp_6dof as six  # noqa: E402
from nlp_reference import load_scenario  # noqa: E402

DATA = ROOT / "crates" / "bellyflop" / "tests" / "data"
OUT = DATA / "six_dof_rhs.json"
ANSWERS = DATA / "six_dof_answers.json"


def answers(count=3, seed=38, N=20):
    """IPOPT's answers for the first `count` states of nlp_6dof.dispersed."""
    path = str(ROOT / "scenarios" / "paper.toml")
    rng = random.Random(seed)
    out = []
    for k in range(count):
        # The same draws, in the same order, as nlp_6dof.dispersed.
        x, z, vx, vz, th, m = (rng.uniform(lo, hi) for lo, hi in six.BOX)
        y, vy = rng.uniform(*six.OUT["y"]), rng.uniform(*six.OUT["vy"])
        psi, phi = (math.radians(rng.uniform(*six.OUT[f])) for f in ("psi_deg", "phi_deg"))
        rates = tuple(math.radians(rng.uniform(*six.OUT["rate_degps"])) for _ in range(3))
        sc = dataclasses.replace(load_scenario(path),
                                 x0=six.np.array([x, z, vx, vz, math.radians(th), 0.0, m]),
                                 mf_guess=m - 5000.0)
        start = six.start_state(sc, y, vy, psi, phi, rates)
        sol = six.Nlp6(sc, N).solve(start, six.attitude(0.0, psi, phi))
        end, lowest = six.reintegrate6(sc, N, start, sol["X"], sol["U"], sol["tf_s"])
        out.append(dict(name=f"box3d{k}", converged=sol["converged"], tf_s=sol["tf_s"],
                        mf_kg=sol["mf_kg"], start=[float(v) for v in start],
                        states=[float(v) for v in sol["X"].ravel()],
                        controls=[float(v) for v in sol["U"].ravel()],
                        flown_end=[float(v) for v in end], flown_lowest_z_m=float(lowest)))
        miss = float(six.np.linalg.norm(end[0:3] - [sc.xf[0], 0.0, sc.xf[1]]))
        print(f"box3d{k}: {sol['status']}, tf {sol['tf_s']:.4f} s, mf {sol['mf_kg']:.3f} kg, "
              f"flown: miss {miss:.3f} m, lowest z {lowest:+.3f} m")
    return out


def main():
    sc = load_scenario(str(ROOT / "scenarios" / "paper.toml"))
    rng = random.Random(38)
    cases = []
    for _ in range(50):
        q = [rng.uniform(-1, 1) for _ in range(4)]
        # Not quite unit: the pull and the normalisation inside R count too.
        n = math.sqrt(sum(x * x for x in q)) / rng.uniform(0.98, 1.02)
        s = ([rng.uniform(-300, 300), rng.uniform(-300, 300), rng.uniform(10, 800)]
             + [rng.uniform(-90, 90) for _ in range(3)]
             + [x / n for x in q]
             + [rng.uniform(-0.5, 0.5) for _ in range(3)]
             + [rng.uniform(9e4, 1.2e5), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)])
        u = [rng.uniform(0.88e6, 2.21e6), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)]
        wind = [rng.uniform(-10, 10), rng.uniform(-10, 10), 0.0]
        f = six.rhs6(sc, s, u, math.sin, math.cos, math.sqrt, wind)
        cases.append(dict(state=s, control=u, wind_mps=wind, rhs=f))
    OUT.write_text(json.dumps(dict(
        note="nlp_6dof.rhs6 at seeded states; written by bench/reference/six_dof_fixture.py",
        kappa_per_s=six.KAPPA, cases=cases), indent=1) + "\n")
    print(f"{len(cases)} cases -> {OUT}")
    ANSWERS.write_text(json.dumps(dict(
        note="nlp_6dof.Nlp6 answers at N = 20 (global LGR mesh, ground at every node, tol 1e-9, "
             "bound_relax_factor 1e-8); written by bench/reference/six_dof_fixture.py",
        nodes=20, answers=answers()), indent=1) + "\n")
    print(f"answers -> {ANSWERS}")


if __name__ == "__main__":
    main()
