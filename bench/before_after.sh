#!/usr/bin/env bash
# The paper's case timed before and after a change of code, side by side
# with the CasADi + IPOPT reference, in one run: REV's release binary and
# this tree's, alternating, ROUNDS times, each the median of REPEAT solves
# in one process (`solve --repeat`), and IPOPT's median of REPEAT solves.
#
#   bench/before_after.sh [REV]      (default: d7ff3b9, the tree before issue 26)
#
# Environment: METHODS (default "direct scvx"), N (default 20), ROUNDS
# (default 3), REPEAT (default 50), WORKTREE (default /tmp/bellyflop-before:
# REV is checked out and built there, and kept for the next run).
# The iteration counts and final masses of both binaries are printed too:
# a restructure must leave them identical.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
REV="${1:-d7ff3b9}"
METHODS="${METHODS:-direct scvx}"
N="${N:-20}"
ROUNDS="${ROUNDS:-3}"
REPEAT="${REPEAT:-50}"
WORKTREE="${WORKTREE:-/tmp/bellyflop-before}"
PY="bench/reference/.venv/bin/python"

die() { echo "before_after.sh: error: $*" >&2; exit 1; }
if [ ! -x "$PY" ]; then
    python3 -m venv bench/reference/.venv || die "python3 -m venv failed"
    bench/reference/.venv/bin/pip install --quiet -r bench/reference/requirements.txt || die "pip install failed"
fi
if [ ! -d "$WORKTREE" ]; then
    git worktree add --detach "$WORKTREE" "$REV" >&2 || die "cannot check out $REV"
fi
(cd "$WORKTREE" && git checkout --quiet --detach "$REV" && cargo build --release --locked --quiet -p bellyflop-cli) \
    || die "cannot build $REV"
cargo build --release --locked --quiet -p bellyflop-cli || die "cannot build this tree"
OLD="$WORKTREE/target/release/bellyflop"
NEW="target/release/bellyflop"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

# ours BIN METHOD -> "median_ms iterations final_mass_kg"
ours() {
    "$1" solve --json --quiet --nodes "$N" --method "$2" --repeat "$REPEAT" > "$TMP/o.json" \
        || die "$1 --method $2 failed"
    python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(d['solve_time_ms'], d['iterations'], repr(d['final_mass_kg']))" "$TMP/o.json"
}
ipopt() {
    "$PY" bench/reference/nlp_reference.py --scenario scenarios/paper.toml --problem P2 \
        --nodes "$N" --repeat "$REPEAT" --json --ground > "$TMP/r.json" 2> "$TMP/r.err" \
        || { cat "$TMP/r.err" >&2; die "IPOPT reference failed"; }
    python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(d['solve_time_ms'])" "$TMP/r.json"
}

echo "bench/before_after.sh  before=$REV ($(cd "$WORKTREE" && git rev-parse --short HEAD))  after=$(git rev-parse --short HEAD)$(git diff --quiet || echo '+dirty')  N=$N  rounds=$ROUNDS  repeat=$REPEAT  $(date -u '+%Y-%m-%d %H:%M UTC')"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
printf '%-7s %5s | %12s %12s %12s | %9s %9s | %6s %6s | %s\n' \
    method round "before [ms]" "after [ms]" "IPOPT [ms]" "before/I" "after/I" "it old" "it new" "same m_f"
for method in $METHODS; do
    for ((r = 1; r <= ROUNDS; r++)); do
        read -r b_ms b_it b_mf < <(ours "$OLD" "$method")
        read -r a_ms a_it a_mf < <(ours "$NEW" "$method")
        i_ms=$(ipopt)
        same=$([ "$b_mf" = "$a_mf" ] && echo yes || echo "NO ($b_mf vs $a_mf)")
        python3 -c "
import sys
b, a, i = map(float, sys.argv[1:4])
print(f'{sys.argv[4]:<7} {sys.argv[5]:>5} | {b:12.3f} {a:12.3f} {i:12.3f} | {b/i:8.3f}x {a/i:8.3f}x | {sys.argv[6]:>6} {sys.argv[7]:>6} | {sys.argv[8]}')
" "$b_ms" "$a_ms" "$i_ms" "$method" "$r" "$b_it" "$a_it" "$same"
    done
done
