#!/usr/bin/env bash
# Does warm-starting the interior-point method across SCvx iterations pay?
# Clarabel 0.11 always starts from its own initial point, so this builds the
# project in a scratch copy against a patched Clarabel
# (bench/experiments/clarabel-warm-start.patch: with CLARABEL_WARM=theta, each
# solve after the first starts from the previous solution shifted into the
# cones' interior by theta) and prints, per N and theta, the cold solve's SCvx
# and interior-point iterations, and the warm re-plan's (examples/replan).
#
#   bench/warm_ipm.sh [N ...]          (default: 20 40)
#
# Environment: THETAS (default "1 0.3 0.1"). "cold" rows are the unpatched
# behaviour (CLARABEL_WARM unset) of the same build. Single runs: iteration
# counts, not timings, are the point. Nothing in the project is changed; the
# scratch copy lives in target/warm-ipm.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
THETAS="${THETAS:-1 0.3 0.1}"
NODES=("$@")
[ ${#NODES[@]} -eq 0 ] && NODES=(20 40)
die() { echo "warm_ipm.sh: error: $*" >&2; exit 1; }
for n in "${NODES[@]}"; do
    [[ "$n" =~ ^[0-9]+$ ]] && [ "$n" -ge 4 ] || die "N must be an integer >= 4 (got '$n')"
done
for t in $THETAS; do
    python3 -c "import sys; v=float(sys.argv[1]); sys.exit(0 if v > 0 else 1)" "$t" 2>/dev/null \
        || die "THETAS must be positive numbers (got '$t')"
done

SCRATCH="$ROOT/target/warm-ipm"
rm -rf "$SCRATCH"
mkdir -p "$SCRATCH/project"
cargo fetch --quiet || die "cargo fetch failed"
SRC="$(ls -d "${CARGO_HOME:-$HOME/.cargo}"/registry/src/*/clarabel-0.11.1 2>/dev/null | head -1)"
[ -d "$SRC" ] || die "clarabel-0.11.1 source not found in the cargo registry"
cp -r "$SRC" "$SCRATCH/clarabel"
patch --quiet -d "$SCRATCH/clarabel" -p1 < bench/experiments/clarabel-warm-start.patch \
    || die "the patch does not apply to $SRC"
git ls-files -z | xargs -0 tar -cf - | tar -xf - -C "$SCRATCH/project"
printf '\n[patch.crates-io]\nclarabel = { path = "%s" }\n' "$SCRATCH/clarabel" >> "$SCRATCH/project/Cargo.toml"
# The patched Clarabel is a path dependency, so its own lint warnings would show.
export RUSTFLAGS="${RUSTFLAGS:-} --cap-lints allow"
(cd "$SCRATCH/project" && cargo build --release --quiet -p bellyflop-cli \
    && cargo build --release --quiet -p bellyflop --example replan) \
    || die "build against the patched Clarabel failed"
BIN="$SCRATCH/project/target/release/bellyflop"
REPLAN="$SCRATCH/project/target/release/examples/replan"
# Run a command with the warm start off ("cold") or at margin theta.
with_theta() {
    local t="$1"
    shift
    if [ "$t" = cold ]; then env -u CLARABEL_WARM "$@"; else CLARABEL_WARM="$t" "$@"; fi
}

echo "Cold solve of scenarios/paper.toml (IPM iterations per SCvx subproblem in brackets):"
printf '%4s %6s | %-8s %5s %5s %12s  %s\n' N theta status SCvx IPM "m_f [kg]" "IPM per subproblem"
for n in "${NODES[@]}"; do
    for t in cold $THETAS; do
        out="$(with_theta "$t" "$BIN" solve --nodes "$n" --json --quiet || true)"
        printf '%s' "$out" | python3 -c '
import json, sys
n, t = sys.argv[1], sys.argv[2]
d = json.load(sys.stdin)
ipm = [h["ipm_iterations"] for h in d["history"]]
shown = ipm if len(ipm) <= 10 else ipm[:10] + ["..."]
print("%4s %6s | %-8s %5d %5d %12.1f  %s" % (n, t, d["status"], d["iterations"], sum(ipm),
      d["final_mass_kg"], " ".join(map(str, shown))))' "$n" "$t"
    done
done

echo
echo "Warm re-plan 0.5 s along the plan (examples/replan; the first re-plan subproblem"
echo "starts cold in every row, the later ones from the previous subproblem's solution):"
for t in cold $THETAS; do
    echo "theta = $t"
    with_theta "$t" "$REPLAN" "${NODES[@]}" || echo "  (replan failed)"
done
