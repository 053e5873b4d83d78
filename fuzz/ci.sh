#!/usr/bin/env bash
# CI: every fuzz target for a short, bounded time (default 20 s each, 10 targets: 3 min 20 s of
# fuzzing, plus the first build), failing on any crash or broken invariant. Needs the nightly
# toolchain; without it, says so and skips. Installs cargo-fuzz when it is missing.
# The targets are the files of fuzz_targets/, so a new target is fuzzed without editing this.
#
#   fuzz/ci.sh                     every target, 20 s each
#   FUZZ_SECONDS=60 fuzz/ci.sh     longer
#   fuzz/ci.sh host_log framing    only these
#
# One fuzzing process at a time, one job each. A crash leaves its input in
# fuzz/artifacts/<target>/; docs/fuzzing.md says how to reproduce it and turn it into a test.
set -euo pipefail
cd "$(dirname "$0")"

seconds=${FUZZ_SECONDS:-20}
targets=()
for f in fuzz_targets/*.rs; do
  targets+=("$(basename "$f" .rs)")
done
if [ $# -gt 0 ]; then
  targets=("$@")
fi

if ! rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
  echo "The nightly toolchain is NOT installed here: the fuzz targets were skipped."
  echo "Install with: rustup toolchain install nightly; then run: fuzz/ci.sh"
  exit 0
fi

if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "== cargo install cargo-fuzz --locked"
  cargo install cargo-fuzz --locked
fi

echo "== seeding fuzz/corpus from the repository"
./seed.sh

echo "== cargo +nightly fuzz build"
cargo +nightly fuzz build

failed=()
for t in "${targets[@]}"; do
  echo "== fuzz $t for ${seconds} s"
  log=$(mktemp)
  if cargo +nightly fuzz run "$t" -- -max_total_time="$seconds" -jobs=1 -workers=1 >"$log" 2>&1; then
    # libFuzzer's last status line: runs, coverage, corpus.
    grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -n1 || tail -n1 "$log"
  else
    echo "!! $t FAILED: a crash or a broken invariant; its log:"
    cat "$log"
    failed+=("$t")
  fi
  rm -f "$log"
done

if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzzing found failures in: ${failed[*]} (inputs in fuzz/artifacts/)"
  exit 1
fi
echo "fuzzing: ${#targets[@]} targets, ${seconds} s each, no failure"
