#!/usr/bin/env bash
# Side-by-side solve times: ours (LGR + SCvx + Clarabel) against the CasADi + IPOPT
# P2 reference (bench/reference/nlp_reference.py), same scenario, N and mesh, one run.
#
#   bench/compare.sh [N ...]        (default: 20 40)
#
# Environment: METHOD (default direct; or scvx), SCENARIO (default scenarios/paper.toml), REPEAT (default 10, >= 10),
# INTERVALS (default 1): LGR mesh intervals M, passed as `--intervals M` to both
# sides (1 = the paper's global mesh; M > 1 = hp mesh, needs N / M >= 2 for every
# N). It overrides the scenario's discretization.intervals on both sides.
# The reference runs with --ground (bellyflop's ground bound z >= z_f), so both
# sides solve one program.
# Both sides time the same way: the median of REPEAT solves from the
# straight-line guess in one process.
# Ours: `bellyflop solve --json --quiet --repeat REPEAT`, whose `solve_time_ms`
# is the median of the method's solve (scenario parsing excluded).
# IPOPT: the reference's `solve_time_ms` with `--repeat REPEAT` (solver build
# time excluded). Until 2026-12-01 ours was the median of REPEAT separate
# processes, each solve cold, against IPOPT's warm calls.
# Any failure (build, non-solved status, IPOPT not converging) aborts the script.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
SCENARIO="${SCENARIO:-scenarios/paper.toml}"
REPEAT="${REPEAT:-10}"
METHOD="${METHOD:-direct}"
INTERVALS="${INTERVALS:-1}"
NODES=("$@")
[ ${#NODES[@]} -eq 0 ] && NODES=(20 40)

die() { echo "compare.sh: error: $*" >&2; exit 1; }
[ "$REPEAT" -ge 10 ] 2>/dev/null || die "REPEAT must be an integer >= 10 (got '$REPEAT')"
[ -f "$SCENARIO" ] || die "scenario '$SCENARIO' not found"
[[ "$INTERVALS" =~ ^[0-9]+$ ]] && [ "$INTERVALS" -ge 1 ] \
    || die "INTERVALS must be an integer >= 1 (got '$INTERVALS')"
for n in "${NODES[@]}"; do
    [[ "$n" =~ ^[0-9]+$ ]] || die "N must be a positive integer (got '$n')"
    [ $((n / INTERVALS)) -ge 2 ] \
        || die "N=$n over INTERVALS=$INTERVALS leaves fewer than 2 points per interval (need INTERVALS <= $((n / 2)))"
done

VENV="bench/reference/.venv"
PY="$VENV/bin/python"
if [ ! -x "$PY" ]; then
    echo "compare.sh: creating $VENV from bench/reference/requirements.txt" >&2
    python3 -m venv "$VENV" || die "python3 -m venv failed"
    "$VENV/bin/pip" install --quiet -r bench/reference/requirements.txt || die "pip install failed"
fi

echo "compare.sh: building target/release/bellyflop" >&2
cargo build --release --quiet -p bellyflop-cli || die "cargo build --release failed"
BIN="target/release/bellyflop"
[ -x "$BIN" ] || die "$BIN not found after the build"

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

# ours N -> prints "median_ms iterations final_mass min_ms max_ms" (fails unless `solved`)
ours() {
    local n="$1" rc=0
    "$BIN" solve --scenario "$SCENARIO" --json --quiet --nodes "$n" \
        --intervals "$INTERVALS" --method "$METHOD" --repeat "$REPEAT" > "$TMP/run.json" || rc=$?
    [ "$rc" -eq 0 ] || die "ours at N=$n M=$INTERVALS: bellyflop exited with $rc"
    python3 - "$TMP/run.json" "$n" "$INTERVALS" "$REPEAT" <<'PY' || die "ours at N=$n M=$INTERVALS: bad output"
import json, sys
d = json.load(open(sys.argv[1]))
if d.get("status") != "solved":
    sys.exit(f"status {d.get('status')!r}: {d.get('message')}")
if d.get("nodes") != int(sys.argv[2]):
    sys.exit(f"nodes {d.get('nodes')} != {sys.argv[2]}")
if "intervals" in d and d["intervals"] != int(sys.argv[3]):
    sys.exit(f"intervals {d['intervals']} != {sys.argv[3]}")
if d.get("repeat") != int(sys.argv[4]):
    sys.exit(f"repeat {d.get('repeat')} != {sys.argv[4]}")
print(f"{d['solve_time_ms']:.3f} {d['iterations']} {d['final_mass_kg']:.3f} "
      f"{d['solve_time_min_ms']:.3f} {d['solve_time_max_ms']:.3f}")
PY
}

# ipopt N -> prints "median_ms iterations final_mass"
ipopt() {
    local n="$1" rc=0
    "$PY" bench/reference/nlp_reference.py --scenario "$SCENARIO" --problem P2 \
        --nodes "$n" --intervals "$INTERVALS" --repeat "$REPEAT" --json --ground \
        > "$TMP/ref_$n.json" 2> "$TMP/ref_$n.err" || rc=$?
    [ "$rc" -eq 0 ] || { cat "$TMP/ref_$n.err" >&2; die "IPOPT reference at N=$n M=$INTERVALS exited with $rc"; }
    python3 - "$TMP/ref_$n.json" "$n" "$INTERVALS" <<'PY' || die "IPOPT reference at N=$n M=$INTERVALS: bad output"
import json, sys
d = json.load(open(sys.argv[1]))
if d.get("success") is not True:
    sys.exit(f"IPOPT did not converge: {d.get('status')!r}")
if d.get("problem") != "P2" or int(d.get("repeat", 0)) < 10:
    sys.exit(f"unexpected reference run: problem {d.get('problem')!r}, repeat {d.get('repeat')!r}")
if d.get("nodes") != int(sys.argv[2]):
    sys.exit(f"nodes {d.get('nodes')} != {sys.argv[2]}")
if "intervals" in d and d["intervals"] != int(sys.argv[3]):
    sys.exit(f"intervals {d['intervals']} != {sys.argv[3]}")
print(f"{float(d['solve_time_ms']):.3f} {d['ipopt_iterations']} {float(d['final_mass_kg']):.3f}")
PY
}

# mesh N -> "global" for M = 1, else the per-interval point counts, e.g. "5+5+5+5"
mesh() {
    local n="$1" k pts=""
    if [ "$INTERVALS" -eq 1 ]; then echo "global"; return; fi
    for ((k = 0; k < INTERVALS; k++)); do
        pts+="${pts:++}$((n / INTERVALS + (k < n % INTERVALS ? 1 : 0)))"
    done
    echo "$pts"
}

if [ "$INTERVALS" -eq 1 ]; then MESH_DESC="global LGR mesh (M=1)"; else MESH_DESC="hp mesh, M=$INTERVALS intervals"; fi
echo "bench/compare.sh  method=$METHOD  scenario=$SCENARIO  repeat=$REPEAT  mesh: $MESH_DESC  $(date -u '+%Y-%m-%d %H:%M UTC')"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
echo
printf '%4s %3s %-16s | %14s %6s %12s | %14s %6s %12s | %13s\n' \
    N M "mesh points" "ours med [ms]" "iters" "m_f [kg]" "IPOPT med [ms]" "iters" "m_f [kg]" "ours/IPOPT"
printf '%s\n' "--------------------------+-------------------------------------+-------------------------------------+--------------"
for n in "${NODES[@]}"; do
    read -r o_ms o_it o_mf o_min o_max < <(ours "$n") || die "ours at N=$n M=$INTERVALS failed"
    read -r r_ms r_it r_mf < <(ipopt "$n") || die "IPOPT at N=$n M=$INTERVALS failed"
    [ -n "${o_ms:-}" ] && [ -n "${r_ms:-}" ] || die "missing timing at N=$n M=$INTERVALS"
    ratio=$(python3 -c "print(f'{$o_ms / $r_ms:.2f}')")
    printf '%4s %3s %-16s | %14s %6s %12s | %14s %6s %12s | %12sx\n' \
        "$n" "$INTERVALS" "$(mesh "$n")" "$o_ms" "$o_it" "$o_mf" "$r_ms" "$r_it" "$r_mf" "$ratio"
    echo "       (ours: min $o_min ms, max $o_max ms over $REPEAT runs)" >&2
done
echo
echo "ratio < 1: ours faster; > 1: ours slower. Both medians over $REPEAT solves."
echo "Both sides solved on the same mesh: N points over M intervals (--intervals $INTERVALS)."
