#!/usr/bin/env bash
# Set up what is missing, then run the test suite: all tests on one rank, then the MPI-marked tests
# under `mpirun -n 2`, after ruff's lint and format checks. Extra arguments go to both pytest runs
# (e.g. -k bearing; -m "not slow" for a quick inner loop without the whole-cycle runs: the MPI run then
# takes the MPI-marked tests that are not slow).
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
# the MPI run keeps its own marker: a given -m EXPR becomes -m "mpi and (EXPR)" (pytest takes the last -m,
# which alone would run every test under mpirun, the serial ones that start mpirun themselves too)
marker="mpi"
rest=()
while [ $# -gt 0 ]; do
    case "$1" in
        -m) marker="mpi and ($2)"; shift 2 ;;
        -m*) marker="mpi and (${1#-m})"; shift ;;
        *) rest+=("$1"); shift ;;
    esac
done
echo "== pytest -m \"$marker\", mpirun -n 2" >&2
status=0
mpirun -n 2 --oversubscribe .venv/bin/python3 -m mpi4py -m pytest -q -m "$marker" -p no:cacheprovider \
    ${rest[@]+"${rest[@]}"} || status=$?
if [ "$status" -eq 5 ]; then  # pytest's "no tests collected": the selection holds no MPI-marked test
    echo "== no MPI-marked test among the selected ones" >&2
    exit 0
fi
exit "$status"
