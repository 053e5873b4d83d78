#!/usr/bin/env bash
# Drives `pmacwd serve` with dls-pmaclib's PmacEthernetInterface, directly and through
# `pmacwd record`, and replays the captures. Installs the client into target/dls-venv.
set -euo pipefail
cd "$(dirname "$0")/../../.."
venv=target/dls-venv
# dls-pmaclib 3.1.2 imports telnetlib, which Python 3.13 removed: use the default python3 when
# it is 3.12 or older, otherwise the newest installed python3.12 ... python3.8, and say which.
usable() { "$1" -c 'import sys; sys.exit(not ((3, 8) <= sys.version_info[:2] <= (3, 12)))' 2>/dev/null; }
python=""
for candidate in python3 python3.12 python3.11 python3.10 python3.9 python3.8; do
  if command -v "$candidate" >/dev/null 2>&1 && usable "$candidate"; then
    python="$candidate"
    break
  fi
done
if [ -z "$python" ]; then
  echo "dls-pmaclib 3.1.2 needs Python 3.8 to 3.12 (it imports telnetlib, removed in 3.13);" \
    "python3 is $(python3 --version 2>&1) and no python3.12 ... python3.8 is installed" >&2
  exit 1
fi
if [ "$python" != python3 ]; then
  echo "python3 is $(python3 --version 2>&1), too new for dls-pmaclib 3.1.2 (telnetlib): using $python ($("$python" --version 2>&1))"
else
  echo "dls-pmaclib runs on $python ($("$python" --version 2>&1))"
fi
# A venv made by another interpreter is made again.
if [ -x "$venv/bin/python" ] && ! cmp -s <("$python" -c 'import sys; print(sys.version)') <("$venv/bin/python" -c 'import sys; print(sys.version)'); then
  rm -rf "$venv"
fi
if [ ! -x "$venv/bin/python" ] || ! cmp -s cli/tests/dls/requirements.txt "$venv/requirements.txt"; then
  rm -rf "$venv"
  "$python" -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r cli/tests/dls/requirements.txt
  cp cli/tests/dls/requirements.txt "$venv/requirements.txt"
fi
cargo build --release --locked --quiet --bin pmacwd
venv_python="$PWD/$venv/bin/python"
cd cli/tests/dls
PMACWD="${CARGO_TARGET_DIR:-$OLDPWD/target}/release/pmacwd" "$venv_python" -m unittest -v test_dls_pmaclib
