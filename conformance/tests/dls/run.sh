#!/usr/bin/env bash
# Drives `pmacwd serve` with dls-pmaclib's PmacEthernetInterface, directly and through
# `pmacwd record`, and replays the captures. Installs the client into target/dls-venv.
set -euo pipefail
cd "$(dirname "$0")/../../.."
venv=target/dls-venv
# dls-pmaclib 3.1.2 imports telnetlib, which Python 3.13 removed.
if ! python3 -c 'import sys; sys.exit(sys.version_info >= (3, 13))'; then
  echo "dls-pmaclib 3.1.2 needs Python <= 3.12 (it imports telnetlib); python3 is $(python3 --version)" >&2
  exit 1
fi
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
