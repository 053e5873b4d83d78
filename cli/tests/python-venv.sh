# Sourced by cli/tests/dls/run.sh and cli/tests/gui/run.sh (from the repository root): makes a
# virtual environment for a Python client pinned by a requirements file, and sets
# `venv_python` to its interpreter.
#
#   python_venv DIR REQUIREMENTS WHAT
#
# dls-pmaclib 3.1.2 imports telnetlib, which Python 3.13 removed, and PyQt5 5.15 wants 3.8 to
# 3.12: the default python3 is used when it is 3.12 or older, otherwise the newest installed
# python3.12 ... python3.8, and the script says which. A venv made by another interpreter, or
# from other requirements, is made again.
python_venv() {
  local venv="$1" requirements="$2" what="$3" python="" candidate
  usable() { "$1" -c 'import sys; sys.exit(not ((3, 8) <= sys.version_info[:2] <= (3, 12)))' 2>/dev/null; }
  for candidate in python3 python3.12 python3.11 python3.10 python3.9 python3.8; do
    if command -v "$candidate" >/dev/null 2>&1 && usable "$candidate"; then
      python="$candidate"
      break
    fi
  done
  if [ -z "$python" ]; then
    echo "$what needs Python 3.8 to 3.12; python3 is $(python3 --version 2>&1) and no python3.12 ... python3.8 is installed" >&2
    exit 1
  fi
  if [ "$python" != python3 ]; then
    echo "python3 is $(python3 --version 2>&1), too new for $what: using $python ($("$python" --version 2>&1))"
  else
    echo "$what runs on $python ($("$python" --version 2>&1))"
  fi
  if [ -x "$venv/bin/python" ] && ! cmp -s <("$python" -c 'import sys; print(sys.version)') <("$venv/bin/python" -c 'import sys; print(sys.version)'); then
    rm -rf "$venv"
  fi
  if [ ! -x "$venv/bin/python" ] || ! cmp -s "$requirements" "$venv/requirements.txt"; then
    rm -rf "$venv"
    "$python" -m venv "$venv"
    "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$requirements"
    cp "$requirements" "$venv/requirements.txt"
  fi
  venv_python="$PWD/$venv/bin/python"
}
