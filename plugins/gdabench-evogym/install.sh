#!/usr/bin/env bash
# Build Evolution Gym 2.0.0 from source in its own virtual environment and install gdabench and
# this plugin into it.  Evolution Gym needs numpy < 2, so it cannot share gdabench's usual venv.
#
#   plugins/gdabench-evogym/install.sh [VENV_DIR]      (default: .venv-evogym at the repository root)
#
# Needs Python 3.11, a C++ compiler, and (installed here with apt-get when missing) the X11
# headers Evolution Gym's bundled GLFW compiles against.  Takes about two minutes.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="${1:-$root/.venv-evogym}"

x11=(libxrandr-dev libxinerama-dev libxcursor-dev libxi-dev)
missing=()
for pkg in "${x11[@]}"; do dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg"); done
if [ "${#missing[@]}" -gt 0 ]; then
  sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get install -y "${missing[@]}"
fi

python3 -m venv "$venv"
. "$venv/bin/activate"
constraints="$venv/constraints.txt"
# torch first and pinned (a CPU build on this kind of machine); numpy<2 for Evolution Gym, and a
# pyarrow that still supports numpy 1.x for gdabench's result tables.
printf 'torch==2.13.0\nnumpy<2\npyarrow<26\n' > "$constraints"
pip install --quiet torch==2.13.0
pip install --quiet -c "$constraints" "numpy<2" "setuptools<81" pybind11==2.13.6
if ! python -c "import evogym" >/dev/null 2>&1; then
  CXXFLAGS="$(python -m pybind11 --includes)" pip install --quiet -c "$constraints" \
    --ignore-requires-python --no-binary evogym evogym==2.0.0
fi
pip install --quiet -c "$constraints" -e "$root[test]" -e "$here"
python - <<'PY'
import contextlib, io
with contextlib.redirect_stdout(io.StringIO()):
    import evogym
import gdabench, numpy
names = gdabench.registry().names("environment")
print(f"Evolution Gym ready: numpy {numpy.__version__}, {sum(n.startswith('evogym/') for n in names)} evogym tasks registered")
PY
echo "activate with: . $venv/bin/activate"
