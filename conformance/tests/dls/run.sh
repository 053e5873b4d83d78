#!/usr/bin/env bash
# Drives `pmacwd serve` with dls-pmaclib's PmacEthernetInterface, directly and through
# `pmacwd record`, and replays the captures. Installs the client into target/dls-venv.
set -euo pipefail
cd "$(dirname "$0")/../../.."
venv=target/dls-venv
if [ ! -x "$venv/bin/python" ] || ! cmp -s conformance/tests/dls/requirements.txt "$venv/requirements.txt"; then
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r conformance/tests/dls/requirements.txt
  cp conformance/tests/dls/requirements.txt "$venv/requirements.txt"
fi
cargo build --release --locked --quiet --bin pmacwd
venv_python="$PWD/$venv/bin/python"
cd conformance/tests/dls
PMACWD="$OLDPWD/target/release/pmacwd" "$venv_python" -m unittest -v test_dls_pmaclib
