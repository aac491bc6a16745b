#!/usr/bin/env bash
# Set up what is missing on a Debian 12 machine, idempotently: Debian packages (dolfinx, gmsh,
# PETSc, MPI, xarray, netCDF4, matplotlib, tqdm, scipy, pytest, ParaView for a test, OpenBLAS), then a virtual environment .venv made
# from /usr/bin/python3 with --system-site-packages, this package installed editable, ruff and import-linter.
# The second run only checks and takes a second or two.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(python3-dolfinx python3-gmsh python3-xarray python3-netcdf4 python3-pytest python3-matplotlib
          python3-tqdm python3-scipy python3-mpi4py python3-petsc4py python3-venv python3-pip openmpi-bin
          paraview python3-paraview  # ParaView's reader checks the time series (tests/study)
          libopenblas0-serial)  # BLAS and LAPACK for numpy, scipy, PETSc and MUMPS instead of Debian's
                                # reference BLAS (README: Benchmarks); serial: one thread per MPI rank
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "setup: installing Debian packages: ${missing[*]}" >&2
    SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -x .venv/bin/python3 ]; then
    echo "setup: creating .venv (system site packages)" >&2
    /usr/bin/python3 -m venv --system-site-packages .venv
fi
stamp=.venv/.tribo-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
    echo "setup: installing the package (editable)" >&2
    .venv/bin/python3 -m pip install -q --no-build-isolation --no-deps -e . >/dev/null
    touch "$stamp"
fi
# ruff checks and formats the code (scripts/test.sh); not packaged by Debian 12: from PyPI, pinned
if ! .venv/bin/python3 -m ruff --version 2>/dev/null | grep -q "ruff 0.17.6"; then
    echo "setup: installing ruff (PyPI) into .venv" >&2
    .venv/bin/python3 -m pip install -q --disable-pip-version-check "ruff==0.17.6" 2>&1 | grep -v "^WARNING: Location" >&2 || true
    .venv/bin/python3 -m ruff --version >/dev/null
fi
# import-linter checks the package's layers (tests/test_layers.py); not packaged by Debian 12: from PyPI
if ! .venv/bin/python3 -c "import importlinter" 2>/dev/null; then
    echo "setup: installing import-linter (PyPI) into .venv" >&2
    .venv/bin/python3 -m pip install -q --disable-pip-version-check "import-linter==2.17" 2>&1 | grep -v "^WARNING: Location" >&2 || true
    .venv/bin/python3 -c "import importlinter"
fi
