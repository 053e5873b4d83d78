#!/usr/bin/env bash
# The soak of issue 30 (docs/emulator.md, "Tests and figures"): 10 GUIs polling dls-pmaccontrol's
# 52-value line through dls-pmaclib while 8 motors jog and home, for SECONDS (default 60); prints
# the server's RSS every 5 s, the polls' p50/p90/p99 and the load average. A measurement run by
# hand, not part of run.sh or .ci/run: it exits 1 only on a wrong answer, a homing search that
# did not complete or a server that died, never on a figure. Installs the client into
# target/dls-venv as run.sh does.
#
#   cli/tests/dls/soak.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/../../.."
seconds="${1:-60}"
case "$seconds" in
  '' | *[!0-9]*) echo "soak.sh: SECONDS must be a whole number of seconds, got '$seconds'" >&2; exit 2 ;;
esac
if [ "$seconds" -lt 15 ] || [ "$seconds" -gt 3600 ]; then
  echo "soak.sh: SECONDS must be 15 to 3600, got $seconds" >&2
  exit 2
fi
source cli/tests/python-venv.sh
python_venv target/dls-venv cli/tests/dls/requirements.txt "dls-pmaclib 3.1.2"
cargo build --release --locked --quiet --bin pmacwd
PMACWD="${CARGO_TARGET_DIR:-$PWD/target}/release/pmacwd" "$venv_python" cli/tests/dls/soak.py "$seconds"
