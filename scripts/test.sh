#!/usr/bin/env bash
# Set up what is missing, then run the test suite: all tests on one rank, then the MPI-marked tests
# under `mpirun -n 2`. Extra arguments go to both pytest runs (e.g. -k bearing).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export PYTHONDONTWRITEBYTECODE=1
echo "== pytest, 1 rank" >&2
.venv/bin/python3 -m pytest -q "$@"
echo "== pytest -m mpi, mpirun -n 2" >&2
mpirun -n 2 --oversubscribe .venv/bin/python3 -m mpi4py -m pytest -q -m mpi -p no:cacheprovider "$@"
