#!/usr/bin/env bash
# Runs DLS's dls-pmaccontrol 3.2.3, unmodified, under a virtual X server against
# `pmacwd serve`, and replays the EPICS pmac driver's poll lists through dls-pmaclib.
# Installs what it needs: the X server and the libraries Qt's xcb plugin loads (Debian
# packages, when missing and we are root), the GUI from PyPI into target/gui-venv.
# Screenshots go to target/gui/.
set -euo pipefail
cd "$(dirname "$0")/../../.."

# Debian packages: Xvfb and the shared libraries the PyQt5 wheel's xcb platform plugin needs.
packages=(xvfb xauth libgl1 libegl1 libglib2.0-0 libfontconfig1 libdbus-1-3 libxkbcommon0
  libxkbcommon-x11-0 libxcb1 libxcb-icccm4 libxcb-image0 libxcb-keysyms1 libxcb-randr0
  libxcb-render-util0 libxcb-xinerama0 libxcb-xkb1 libxcb-shape0 libxcb-xfixes0 libxcb-cursor0)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  if [ "$(id -u)" != 0 ]; then
    echo "missing Debian packages: ${missing[*]}; install them (apt-get install ${missing[*]}) or run as root" >&2
    exit 1
  fi
  echo "installing Debian packages: ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# PyQt5 5.15 and dls-pmaclib (telnetlib) want Python 3.8 to 3.12.
source cli/tests/python-venv.sh
python_venv target/gui-venv cli/tests/gui/requirements.txt "dls-pmaccontrol 3.2.3"
cargo build --release --locked --quiet --bin pmacwd
mkdir -p target/gui
export PMACWD="${CARGO_TARGET_DIR:-$PWD/target}/release/pmacwd" SCREENSHOTS="$PWD/target/gui" EPICS_PMAC_SOURCE="$PWD/cli/tests/gui"
cd cli/tests/gui
# -a: a free display number; the GUI gets its own X server for the run and nothing else.
xvfb-run -a -s "-screen 0 1280x1024x24" "$venv_python" -m unittest -v test_dls_pmaccontrol test_epics_poll
