#!/usr/bin/env bash
# Set up what is missing, then run the test suite: all tests on one rank, then the MPI-marked tests
# under `mpirun -n 2`, after ruff's lint and format checks. Extra arguments go to both pytest runs
# (e.g. -k bearing; -m "not slow" for a quick inner loop without the whole-cycle runs).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export PYTHONDONTWRITEBYTECODE=1
echo "== ruff check, ruff format --check" >&2
.venv/bin/python3 -m ruff check --quiet solver tests bench
.venv/bin/python3 -m ruff format --check --quiet solver tests bench
echo "== pytest, 1 rank" >&2
.venv/bin/python3 -m pytest -q "$@"
echo "== pytest -m mpi, mpirun -n 2" >&2
mpirun -n 2 --oversubscribe .venv/bin/python3 -m mpi4py -m pytest -q -m mpi -p no:cacheprovider "$@"
