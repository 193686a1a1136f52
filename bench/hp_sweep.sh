#!/usr/bin/env bash
# Cold solves of the paper's case on hp meshes: N in {20, 40} x M intervals x
# t_f guesses, one line each (status, SCvx iterations, final mass, solve time).
#
#   bench/hp_sweep.sh            # from the repository root; needs a release build
#
# Shows how often SCvx converges through the relaxed phase on an hp mesh and
# whether every run reaches the same optimum (BENCHMARKS.md, "hp mesh").
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=target/release/bellyflop
[ -x "$BIN" ] || cargo build --release
TMP="$(mktemp)"
trap 'rm -f "$TMP"' EXIT
printf '%4s %4s %6s  %-10s %5s %12s %9s\n' N M tf0_s status iters m_f_kg ms
for n in 20 40; do
    for m in 2 4 5 8 10; do
        for tf in 8 12 16 20; do
            sed "s/^tf_guess_s = .*/tf_guess_s = $tf.0/" scenarios/paper.toml > "$TMP"
            "$BIN" solve --scenario "$TMP" --nodes "$n" --intervals "$m" --json --quiet \
                | python3 -c "
import json, sys
d = json.load(sys.stdin)
print('%4d %4d %6d  %-10s %5d %12.2f %9.0f' % ($n, $m, $tf, d['status'], d['iterations'], d['final_mass_kg'], d['solve_time_ms']))"
        done
    done
done
