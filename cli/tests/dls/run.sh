#!/usr/bin/env bash
# Drives `pmacwd serve` with dls-pmaclib's PmacEthernetInterface, directly and through
# `pmacwd record`, and replays the captures; then the EPICS pmac driver's motor-record moves,
# stop, home and kill (test_epics_motion.py), and its coordinate-system moves
# (test_epics_cs_motion.py). Installs the client into target/dls-venv.
set -euo pipefail
cd "$(dirname "$0")/../../.."
source cli/tests/python-venv.sh
python_venv target/dls-venv cli/tests/dls/requirements.txt "dls-pmaclib 3.1.2"
cargo build --release --locked --quiet --bin pmacwd
cd cli/tests/dls
PMACWD="${CARGO_TARGET_DIR:-$OLDPWD/target}/release/pmacwd" "$venv_python" -m unittest -v test_dls_pmaclib test_epics_motion test_epics_cs_motion
