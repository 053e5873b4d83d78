#!/bin/sh
# Generates, compiles and runs the SPIN twin of a checked configuration (issue 32), and prints
# its state count and CPU time. Usage: model/spin/run.sh [MODEL] (default timing: the file
# model/spin/MODEL.pml). Needs spin, gcc and /usr/bin/time; installs those missing from Debian
# (as root).
#
# The flags, and why (each keeps pan's search an exhaustive search of the same state set as
# `pmacwd check --configuration timing --profile um-215`):
#   spin -o2      keep write-only variables in the state vector. The ghost recovered_by is read
#                 only by the checker's `sometimes` properties, which Promela's asserts do not
#                 state; spin would otherwise drop it and merge states the checker keeps apart
#                 (28,164 states instead of 57,536).
#   -DSAFETY      a safety search (asserts, no acceptance cycles): what stateright's BFS checks.
#   -DNOREDUCE    no partial-order reduction (one process: nothing to reduce; stated so).
#   -O2           gcc's usual optimisation for pan.
#   pan -w18      a hash table of 2^18 slots (full state storage, chained: no state is lost
#                 whatever the size; 2^18 is over four times the states).
# No -DBITSTATE, -DHC or -DCOLLAPSE: every state is stored whole, as stateright stores its
# fingerprints (exact storage either way).
set -eu
model=${1:-timing}
here=$(cd "$(dirname "$0")" && pwd)
# Debian bookworm's spin is 6.5.2 (the version measured in docs/model.md); gcc compiles pan,
# /usr/bin/time (package time) measures it.
missing=""
command -v spin >/dev/null 2>&1 || missing="$missing spin"
command -v gcc >/dev/null 2>&1 || missing="$missing gcc"
[ -x /usr/bin/time ] || missing="$missing time"
if [ -n "$missing" ]; then
    if [ "$(id -u)" = 0 ]; then
        apt-get install -y $missing >&2
    else
        echo "run.sh: not installed:$missing (apt-get install -y$missing, as root)" >&2
        exit 2
    fi
fi
if [ ! -f "$here/$model.pml" ]; then
    echo "run.sh: no twin $here/$model.pml (there are: $(cd "$here" && ls *.pml | sed 's/\.pml$//' | tr '\n' ' '))" >&2
    exit 2
fi
# SPIN_WORK: where pan is built and kept; by default a temporary directory, removed after.
if [ -n "${SPIN_WORK:-}" ]; then
    work=$SPIN_WORK
else
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work"
cp "$here/$model.pml" "$work/"
cd "$work"
spin -o2 -a "$model.pml" >/dev/null
gcc -O2 -g -DNOREDUCE -DSAFETY -o pan pan.c
out=$( { /usr/bin/time -f 'cpu %U %S' ./pan -w18; } 2>&1 )
states=$(printf '%s\n' "$out" | sed -n 's/^ *\([0-9]*\) states, stored.*/\1/p')
transitions=$(printf '%s\n' "$out" | sed -n 's/^ *\([0-9]*\) transitions.*/\1/p')
errors=$(printf '%s\n' "$out" | sed -n 's/.*errors: \([0-9]*\).*/\1/p')
cpu=$(printf '%s\n' "$out" | sed -n 's/^cpu \([0-9.]*\) \([0-9.]*\)$/\1 \2/p')
echo "spin $(spin -V | sed 's/Spin Version \([^ ]*\).*/\1/') model $model: $states states, $transitions transitions, errors $errors"
echo "pan user+sys: $cpu s"
[ "$errors" = 0 ]
