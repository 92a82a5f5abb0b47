#!/usr/bin/env bash
# Mutation testing of the optimizers in algorithms/ with mutmut (see docs/mutation-testing.md).
#
#   bash benchmarks/mutation_algorithms.sh [WORKDIR]     (default WORKDIR: /tmp/metaknot-mutation)
#
# The checkout is never touched: the committed tree (git archive HEAD) is laid out in WORKDIR
# with the installed package layout (algorithms/ -> metaknot/algorithms/, problems/ ->
# metaknot/problems/, experiments/ -> metaknot/experiments/), so the file paths mutmut mutates
# match the module names the tests import (metaknot.algorithms.dolphin, ...). mutmut puts its
# mutants/ tree first on sys.path, ahead of the editable install of the checkout.
# One worker (--max-children 1); the summary is printed at the end and kept in WORKDIR/results.txt.
# Environment: PYTHON (default .venv/bin/python of the checkout), MUTATE (space-separated file
# names in algorithms/, default: the optimizers below), REV (git revision, default HEAD).
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${1:-/tmp/metaknot-mutation}
PYTHON=${PYTHON:-$ROOT/.venv/bin/python}
REV=${REV:-HEAD}
MUTATE=${MUTATE:-"dolphin.py ga.py one_plus_one.py local_search.py nlopt_knots.py knot_map.py baselines.py random_search.py"}
TESTS=(tests/test_dolphin.py tests/test_ga.py tests/test_local_methods.py tests/test_baselines.py
       tests/test_nlopt.py tests/test_adapters.py tests/test_all_optimizers.py
       tests/test_mutation_kills.py)
# Left out: tests marked slow, the 40-point runs of the global nlopt methods (the 20-point runs
# stay), and the NGOpt test, which runs the checkout's package in a subprocess (not the mutants).
DESELECT=(tests/test_adapters.py::test_ngopt_surrogate_failure_falls_back_and_the_process_exits)
for curve in archimedean epitrochoid vivaldi; do
    DESELECT+=("tests/test_nlopt.py::test_global_methods_stay_feasible_and_improve_on_the_averaging_start[40-$curve]")
done
MUTMUT=$(dirname "$PYTHON")/mutmut
[ -x "$MUTMUT" ] || { echo "mutmut is not installed: $(dirname "$PYTHON")/pip install mutmut"; exit 1; }

rm -rf "$WORK"
mkdir -p "$WORK/src" "$WORK/run"
git -C "$ROOT" archive "$REV" | tar -x -C "$WORK/src"
cp -r "$WORK/src/metaknot" "$WORK/run/metaknot"
for sub in algorithms problems experiments; do
    cp -r "$WORK/src/$sub" "$WORK/run/metaknot/$sub"
done
cp -r "$WORK/src/tests" "$WORK/run/tests"

selection=()
for t in "${TESTS[@]}"; do [ -f "$WORK/run/$t" ] && selection+=("\"$t\""); done
deselect=()
for d in "${DESELECT[@]}"; do deselect+=("\"--deselect\"" "\"$d\""); done
only=()
for f in $MUTATE; do only+=("\"metaknot/algorithms/$f\""); done
join() { local IFS=,; echo "$*"; }

cat >"$WORK/run/pyproject.toml" <<EOF
[tool.mutmut]
timeout_multiplier = 5.0
source_paths = ["metaknot"]
only_mutate = [$(join "${only[@]}")]
pytest_add_cli_args_test_selection = [$(join "${selection[@]}")]
pytest_add_cli_args = ["-p", "no:cacheprovider", "-p", "no:xdist", "-m", "not slow", $(join "${deselect[@]}")]

[tool.pytest.ini_options]
testpaths = ["tests"]
addopts = "--strict-markers"
markers = ["slow: takes seconds or more"]
EOF

# One core. mutmut forks a child per mutant from a parent that has run the tests: numba's
# default threading layer here (GNU OpenMP) terminates a forked child (SIGTERM, reported by
# mutmut as "suspicious"); the workqueue layer is fork-safe.
export NUMBA_THREADING_LAYER=workqueue NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1

cd "$WORK/run"
echo "mutmut $("$PYTHON" -c 'import importlib.metadata as m; print(m.version("mutmut"))'), tree $(git -C "$ROOT" rev-parse --short "$REV"), mutating: $MUTATE"
start=$(date +%s)
"$MUTMUT" run --max-children 1 || true
echo "wall time: $(( $(date +%s) - start )) s"
"$MUTMUT" results --all true >"$WORK/results.txt" 2>&1 || "$MUTMUT" results --all >"$WORK/results.txt" 2>&1 || true
awk '{print $NF}' "$WORK/results.txt" | sort | uniq -c
: >"$WORK/survivors.diff"
for name in $(awk '$NF != "killed" {sub(":$", "", $1); print $1}' "$WORK/results.txt"); do
    "$MUTMUT" show "$name" >>"$WORK/survivors.diff" 2>&1
done
echo "not killed: $WORK/results.txt, their diffs: $WORK/survivors.diff"
