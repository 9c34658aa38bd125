#!/usr/bin/env bash
# Idempotent set-up: Debian's FEniCSx stack (apt, when missing), then .venv with
# the package installed editable. Quick when everything is already there.
set -euo pipefail
cd "$(dirname "$0")/.."

# OpenBLAS: MUMPS on the 27.9k-DOF P2 bend takes 89 s with Debian's reference BLAS,
# 31 s with OpenBLAS (serial or one thread), 27 s with the pthread build on 2 threads.
APT_PACKAGES=(
  python3-dolfinx-real python3-gmsh python3-nlopt python3-h5py python3-venv
  python3-yaml python3-matplotlib python3-scipy python3-pytest python3-pytest-xdist python3-setuptools
  python3-nbclient python3-nbformat python3-ipykernel
  libopenblas0-pthread openmpi-bin
)

missing=()
for pkg in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" != 0 ]; then
    command -v sudo >/dev/null || { echo "setup: need root (or sudo) to install ${missing[*]}" >&2; exit 1; }
    SUDO=sudo
  fi
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The Debian interpreter sees the compiled stack; the python3 first on PATH may not.
PY=/usr/bin/python3
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv (system site packages visible)"
  "$PY" -m venv --system-site-packages .venv
fi

# Pin Debian's numpy so that pip never replaces it under the compiled modules.
.venv/bin/python -c "import numpy; print(f'numpy=={numpy.__version__}')" > constraints.txt
echo "setup: installing shapegrowth (editable) into .venv"
PIP_DISABLE_PIP_VERSION_CHECK=1 .venv/bin/pip install -q --no-build-isolation -c constraints.txt -e ".[test,notebooks]"
# The notebooks' kernel "python3" must be this environment's python (Debian's own
# kernelspec would start /usr/bin/python3, which lacks numba); .venv's spec wins.
if [ ! -f .venv/share/jupyter/kernels/python3/kernel.json ]; then
  .venv/bin/python -m ipykernel install --sys-prefix --name python3 \
    --display-name "Python 3 (shapegrowth .venv)" > /dev/null
fi
.venv/bin/python -c "import dolfinx, shapegrowth; print(f'setup: ok (dolfinx {dolfinx.__version__}, shapegrowth {shapegrowth.__version__})')"
