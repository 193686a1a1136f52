#!/usr/bin/env bash
# Regenerates docs/validation.md: builds bellyflop, runs `bellyflop sweep` and the
# CasADi+IPOPT reference (P1 and P2) at N = 15, 20, 30, 40, and writes the report.
#
#   bench/validation.sh                 # from the repository root
#   bench/validation.sh --repeat 3      # extra options go to bench/validation_report.py
#
# Exits non-zero if the build, any solve, or the report fails.
set -euo pipefail

cd "$(dirname "$0")/.."

VENV=bench/reference/.venv
if [ ! -x "$VENV/bin/python" ]; then
    echo "validation.sh: creating $VENV" >&2
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install -r bench/reference/requirements.txt
fi

echo "validation.sh: cargo build --release" >&2
cargo build --release

exec "$VENV/bin/python" bench/validation_report.py --command "bench/validation.sh${*:+ $*}" "$@"
