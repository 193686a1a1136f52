#!/usr/bin/env python3
"""Writes crates/bellyflop/tests/data/six_dof_rhs.json: the 6-DoF right-hand
side of nlp_6dof.py (written apart from the Rust model) at seeded states
out of the plane, for the Rust test that checks its own model against it
(crates/bellyflop/tests/six_dof.rs). The vehicle is the paper's; a wind
along x and across.

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

OUT = ROOT / "crates" / "bellyflop" / "tests" / "data" / "six_dof_rhs.json"


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


if __name__ == "__main__":
    main()
