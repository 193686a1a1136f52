#!/usr/bin/env bash
# Ours (default `exact` formulation) against the CasADi + IPOPT P2 reference on
# the six dispersed initial states of examples/convergence.rs, same scenario
# otherwise, from each side's straight-line guess. One line per state and N:
# status, iterations, median solve time of REPEAT runs, final mass, and the
# landing error of the re-propagated open-loop controls.
#
#   bench/dispersed_vs_ipopt.sh            # N = 20
#   bench/dispersed_vs_ipopt.sh 20 40      # several N
#   REPEAT=5 bench/dispersed_vs_ipopt.sh   # timing repetitions (default 3)
#
# Landing errors: ours re-propagates with DOP853 and pchip controls
# (`bellyflop solve`), the reference with DOP853 and linearly interpolated
# controls (nlp_reference.py); both from the N collocation points. The
# reference has no ground bound (z >= z_f); "min z" shows whether its answer
# stays above the pad, i.e. is feasible for ours too.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=target/release/bellyflop
PY=bench/reference/.venv/bin/python
REPEAT=${REPEAT:-3}
[ -x "$BIN" ] || cargo build --release
[ -x "$PY" ] || { python3 -m venv bench/reference/.venv && "$PY" -m pip install -r bench/reference/requirements.txt; }
NODES=("$@")
[ ${#NODES[@]} -gt 0 ] || NODES=(20)
TMP="$(mktemp)"
trap 'rm -f "$TMP"' EXIT
printf '%-3s %-38s | %-7s %4s %8s %10s %6s %6s | %4s %7s %10s %6s %6s %6s | %8s\n' \
    N "x0 z0 vx0 vz0 theta0 m0" ours its "ms" "m_f [kg]" "pos m" "vel" \
    its "ms" "m_f [kg]" "pos m" "vel" "min z" "ref-ours"
for N in "${NODES[@]}"; do
while read -r x z vx vz th m; do
    python3 - "$x" "$z" "$vx" "$vz" "$th" "$m" > "$TMP" <<'PYEOF'
import re, sys
x, z, vx, vz, th, m = sys.argv[1:]
s = open("scenarios/paper.toml").read()
for key, val in [("x_m", x), ("z_m", z), ("vx_mps", vx), ("vz_mps", vz),
                 ("theta_deg", th), ("mass_kg", m)]:
    s = re.sub(rf"(?m)^{key} = .*", f"{key} = {val}", s, count=1)
s = re.sub(r"(?m)^final_mass_guess_kg = .*", f"final_mass_guess_kg = {float(m) - 5000.0}", s, count=1)
print(s)
PYEOF
    ours=()
    for _ in $(seq "$REPEAT"); do
        ours+=("$("$BIN" solve --scenario "$TMP" --nodes "$N" --json --quiet || true)")
    done
    ref=$("$PY" bench/reference/nlp_reference.py --scenario "$TMP" --nodes "$N" --problem P2 --repeat "$REPEAT" --json)
    python3 - "$N" "$x $z $vx $vz $th $m" "$ref" "${ours[@]}" <<'PYEOF'
import json, statistics, sys
n, label, r = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
runs = [json.loads(s) for s in sys.argv[4:]]
o = runs[0]
ms = statistics.median(run["solve_time_ms"] for run in runs)
lo, lr = o["landing_error"], r["landing_error"]
print("%-3s %-38s | %-7s %4d %8.1f %10.1f %6.1f %6.2f | %4d %7.1f %10.1f %6.1f %6.2f %6.2f | %8.1f" % (
    n, label, o["status"], o["iterations"], ms, o["final_mass_kg"], lo["position_m"],
    lo["velocity_mps"], r["ipopt_iterations"], r["solve_time_ms"], r["final_mass_kg"],
    lr["position_m"], lr["velocity_mps"], min(r["z_m"]), r["final_mass_kg"] - o["final_mass_kg"]))
PYEOF
done <<'EOF2'
-200.0 500.0 15.0 -70.0 80.0 110000.0
200.0 800.0 -15.0 -95.0 95.0 125000.0
0.0 650.0 0.0 -80.0 88.0 118000.0
150.0 550.0 10.0 -90.0 85.0 122000.0
-120.0 750.0 -8.0 -75.0 92.0 112000.0
60.0 700.0 5.0 -88.0 82.0 124000.0
EOF2
done
