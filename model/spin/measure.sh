#!/bin/sh
# The checker against its SPIN twin on equal work (issue 32), measured in one run, interleaved
# (pan, checker, pan, checker, ...), CPU time (user+sys, /usr/bin/time) and instructions
# (valgrind's callgrind, which do not depend on the load). Usage, from the workspace root:
#
#   cargo build --release -p pmacwd-cli -p pmacwd-model --example check_instructions
#   model/spin/measure.sh [ROUNDS] [RUNS] [CONFIGURATION]   # default 5 rounds of 20 runs, timing
#
# CONFIGURATION is `timing` or `i40-zero` (each has its twin, model/spin/CONFIGURATION.pml).
# Per round: RUNS runs of pan (the whole process: its search, with its hash table's set-up);
# RUNS runs of the checker's search alone (`check_instructions RUNS` less
# `check_instructions 0`: the benchmark's whole check of `timing`, model construction and the
# checker's maps included, without the specs' loading); RUNS runs of the checker's whole
# process (`pmacwd check --configuration CONFIGURATION --profile um-215 --threads 1
# --no-conformance`). Prints each round's CPU per state and the medians' ratios.
#
# BEFORE=DIR (optional): DIR is the release directory of an earlier build (its
# examples/check_instructions and pmacwd), measured in the same rounds, interleaved with this
# one (pan, checker, earlier checker, ...): a paired A/B on equal work. To build one:
#
#   git archive COMMIT | tar -x -C /tmp/before && (cd /tmp/before &&
#     CARGO_TARGET_DIR=/tmp/before-target cargo build --release -p pmacwd-cli &&
#     CARGO_TARGET_DIR=/tmp/before-target cargo build --release -p pmacwd-model --example check_instructions)
#   BEFORE=/tmp/before-target/release model/spin/measure.sh 5 20 timing
set -eu
rounds=${1:-5}
runs=${2:-20}
config=${3:-timing}
target=${CARGO_TARGET_DIR:-target}/release
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
SPIN_WORK=$work "$here/run.sh" "$config" >/dev/null
states=$(cd "$work" && ./pan -w18 | sed -n 's/^ *\([0-9]*\) states, stored.*/\1/p')
cpu() { # user+sys seconds of a command
    /usr/bin/time -f '%U %S' "$@" 2>&1 >/dev/null | tail -1 | awk '{printf "%.3f", $1 + $2}'
}
loop() { # RUNS runs of a command in one shell
    sh -c 'n=$1; shift; i=0; while [ $i -lt $n ]; do "$@"; i=$((i+1)); done' loop "$runs" "$@"
}
per_state() { awk -v t="$1" -v n="$runs" -v s="$states" 'BEGIN { printf "%.0f", t / n / s * 1e9 }'; }
echo "$config: states $states, $rounds rounds of $runs runs, load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
before=${BEFORE:-}
if [ -n "$before" ]; then
    echo "round  pan_ns/state  checker_search_ns/state  checker_process_ns/state  before_search_ns/state  before_process_ns/state"
else
    echo "round  pan_ns/state  checker_search_ns/state  checker_process_ns/state"
fi
search_cpu() { # the CPU of RUNS searches of the checker in release directory $1
    full=$(cpu "$1/examples/check_instructions" "$runs" "$config")
    none=$(cpu "$1/examples/check_instructions" 0 "$config")
    awk -v a="$full" -v b="$none" 'BEGIN { printf "%.3f", a - b }'
}
process_cpu() { # the CPU of RUNS whole processes of `pmacwd check` in release directory $1
    cpu sh -c 'n=$1; shift; i=0; while [ $i -lt $n ]; do "$@" >/dev/null; i=$((i+1)); done' x "$runs" \
        "$1/pmacwd" check --configuration "$config" --profile um-215 --threads 1 --no-conformance
}
: > "$work/rows"
r=1
while [ "$r" -le "$rounds" ]; do
    pan=$(cd "$work" && cpu sh -c 'n=$1; i=0; while [ $i -lt $n ]; do ./pan -w18 >/dev/null; i=$((i+1)); done' x "$runs")
    search=$(search_cpu "$target")
    proc=$(process_cpu "$target")
    row="$(per_state "$pan") $(per_state "$search") $(per_state "$proc")"
    if [ -n "$before" ]; then
        row="$row $(per_state "$(search_cpu "$before")") $(per_state "$(process_cpu "$before")")"
    fi
    echo "$r      $row"
    echo "$row" >> "$work/rows"
    r=$((r + 1))
done
echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)"
median() { sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
p=$(cut -d' ' -f1 "$work/rows" | median)
s=$(cut -d' ' -f2 "$work/rows" | median)
w=$(cut -d' ' -f3 "$work/rows" | median)
awk -v p="$p" -v s="$s" -v w="$w" 'BEGIN { printf "medians: pan %s ns/state, checker search %s (%.2fx), checker process %s (%.2fx)\n", p, s, s / p, w, w / p }'
if [ -n "$before" ]; then
    bs=$(cut -d' ' -f4 "$work/rows" | median)
    bw=$(cut -d' ' -f5 "$work/rows" | median)
    awk -v p="$p" -v s="$s" -v w="$w" -v bs="$bs" -v bw="$bw" 'BEGIN {
        printf "before: search %s (%.2fx pan), process %s (%.2fx pan); this build over it: search %.3f, process %.3f\n",
            bs, bs / p, bw, bw / p, s / bs, w / bw }'
fi
if [ "${INSTRUCTIONS:-1}" = 1 ] && command -v valgrind >/dev/null; then
    count() { valgrind --tool=callgrind --callgrind-out-file=/dev/null "$@" 2>&1 >/dev/null | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'; }
    ip=$(cd "$work" && count ./pan -w18)
    i1=$(count "$target/examples/check_instructions" 1 "$config")
    i0=$(count "$target/examples/check_instructions" 0 "$config")
    iw=$(count "$target/pmacwd" check --configuration "$config" --profile um-215 --threads 1 --no-conformance)
    awk -v p="$ip" -v a="$i1" -v b="$i0" -v w="$iw" -v s="$states" 'BEGIN {
        printf "instructions per state: pan %.0f (whole process), checker search %.0f (%.2fx), checker process %.0f (%.2fx)\n",
            p / s, (a - b) / s, (a - b) / p, w / s, w / p }'
    if [ -n "$before" ]; then
        j1=$(count "$before/examples/check_instructions" 1 "$config")
        j0=$(count "$before/examples/check_instructions" 0 "$config")
        jw=$(count "$before/pmacwd" check --configuration "$config" --profile um-215 --threads 1 --no-conformance)
        awk -v p="$ip" -v a="$j1" -v b="$j0" -v w="$jw" -v s="$states" 'BEGIN {
            printf "instructions per state before: checker search %.0f (%.2fx), checker process %.0f (%.2fx)\n",
                (a - b) / s, (a - b) / p, w / s, w / p }'
    fi
fi
rm -rf "$work"
