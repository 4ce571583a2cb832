#!/usr/bin/env bash
# The iterative path on a GPU (issue 47 item 4), run on the device machine from the repository root:
#   bash benchmarks/gpu_assembly.sh small   # ~4 min: the GPU tests, iterative-gpu at 10^4 and 10^5 dofs, the CPU path at 10^5
#   bash benchmarks/gpu_assembly.sh large   # ~5 min: iterative-gpu at 10^6 dofs
# (two calls: each within the device tool's 10-minute limit on one command). The machine has numpy, scipy,
# CuPy, numba and pytest, not pyamg or Biopython: their wheels for its Python go in .whl/ first, here:
#   echo /.whl/ >> .git/info/exclude
#   python3 -m pip download --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
#       --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
#       -d .whl pyamg==5.3.0 biopython==1.85
# and the call carries .whl. Writes $OUT/env.txt, $OUT/pytest.txt and one JSON row per run to $OUT/rows.jsonl
# (bench_assembly.py --one: time, iterations, residual, estimate, the GPU's peak memory, the path's stages).
set -u
part=${1:-small}
ls .whl/*.whl > /dev/null 2>&1 || { echo "no wheels in .whl/: see the header of $0"; exit 1; }
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
if [ "$part" = small ]; then
  one iterative-gpu 10000 60
  timeout 150 python3 -m pytest -q -p no:cacheprovider tests/solvers/test_iterative_device.py tests/solvers/test_gpu.py \
    > "$OUT/pytest.txt" 2>&1; echo "pytest rc=$?"; tail -n 15 "$OUT/pytest.txt"
  one iterative-gpu 100000 120
  one iterative 100000 150
else
  one iterative-gpu 1000000 480
fi
