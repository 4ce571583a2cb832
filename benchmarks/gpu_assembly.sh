#!/usr/bin/env bash
# The iterative path on a GPU (issue 47 item 4): run on the device machine from the repository root, with
# pyamg's and Biopython's wheels for its Python in .whl/ (the machine has numpy, scipy, CuPy, pytest).
# Writes $OUT/env.txt, $OUT/pytest.txt and one JSON row per run to $OUT/rows.jsonl (bench_assembly.py --one).
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1 VIBRA_AOT=0
OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
{ nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv; nproc
  python3 -c "import sys, numpy, scipy, cupy, pyamg, numba; print(sys.version); print('numpy', numpy.__version__, 'scipy', scipy.__version__, 'cupy', cupy.__version__, 'pyamg', pyamg.__version__, 'numba', numba.__version__)"
} > "$OUT/env.txt" 2>&1
cat "$OUT/env.txt"
one() {  # METHOD DOFS SECONDS
  echo "== $1 $2"
  (cd benchmarks && timeout "$3" python3 bench_assembly.py --one "$1" "$2") > "$OUT/row.txt" 2> "$OUT/err-$1-$2.txt"
  echo "rc=$?"; tail -n 1 "$OUT/row.txt" | tee -a "$OUT/rows.jsonl" | cut -c1-600; tail -n 5 "$OUT/err-$1-$2.txt"
}
one iterative-gpu 10000 90
timeout 200 python3 -m pytest -q -p no:cacheprovider tests/solvers/test_iterative_device.py tests/solvers/test_gpu.py \
  > "$OUT/pytest.txt" 2>&1; echo "pytest rc=$?"; tail -n 15 "$OUT/pytest.txt"
one iterative-gpu 100000 120
one iterative 100000 150
one iterative-gpu 1000000 ${LAST_SECONDS:-330}
