#!/usr/bin/env bash
# Final masses of ours (default `exact` formulation) and of the CasADi + IPOPT
# P2 reference on the six dispersed initial states of examples/convergence.rs,
# same scenario otherwise, N = 20 global mesh. One line per state.
#
#   bench/dispersed_vs_ipopt.sh        # from the repository root
#
# The reference has no ground bound (z >= z_f); "ref min z" shows whether its
# answer stays above the pad, i.e. is feasible for ours too.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=target/release/bellyflop
PY=bench/reference/.venv/bin/python
[ -x "$BIN" ] || cargo build --release
[ -x "$PY" ] || { python3 -m venv bench/reference/.venv && "$PY" -m pip install -r bench/reference/requirements.txt; }
TMP="$(mktemp)"
trap 'rm -f "$TMP"' EXIT
printf '%-42s %-8s %5s %11s | %11s %10s %9s\n' "x0 z0 vx0 vz0 theta0 m0" ours iters "m_f [kg]" "IPOPT m_f" "ref-ours" "ref min z"
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
    ours=$("$BIN" solve --scenario "$TMP" --json --quiet || true)
    ref=$("$PY" bench/reference/nlp_reference.py --scenario "$TMP" --nodes 20 --problem P2 --json)
    python3 - "$ours" "$ref" "$x $z $vx $vz $th $m" <<'PYEOF'
import json, sys
o, r, label = json.loads(sys.argv[1]), json.loads(sys.argv[2]), sys.argv[3]
print("%-42s %-8s %5d %11.1f | %11.1f %10.1f %9.2f" % (
    label, o["status"], o["iterations"], o["final_mass_kg"], r["final_mass_kg"],
    r["final_mass_kg"] - o["final_mass_kg"], min(r["z_m"])))
PYEOF
done <<'EOF2'
-200.0 500.0 15.0 -70.0 80.0 110000.0
200.0 800.0 -15.0 -95.0 95.0 125000.0
0.0 650.0 0.0 -80.0 88.0 118000.0
150.0 550.0 10.0 -90.0 85.0 122000.0
-120.0 750.0 -8.0 -75.0 92.0 112000.0
60.0 700.0 5.0 -88.0 82.0 124000.0
EOF2
