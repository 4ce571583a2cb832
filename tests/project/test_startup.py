"""Tests of start-up (issue 45): what ``vibra --help`` and a small problem's first call load, and the
compiled kernels' loading on first call (`vibra.solvers.compiled`).

No clock: each check runs a fresh interpreter and reads `sys.modules` (what ``import vibra`` itself
loads: `tests/project/test_package.test_import_vibra_is_light`, on the same list `HEAVY`). Truth for the routes a
size chooses: the other route (the same bits, or the same accuracy) and numpy's SVD.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from helpers.package import HEAVY
from vibra.solvers import compiled
from vibra.solvers.accurate import products
from vibra.solvers.accurate import gk_bisection

ROOT = Path(__file__).resolve().parents[2]
EPS = float(np.finfo(float).eps)

#: Builds a system in a fresh interpreter (`benchmarks/corpus.py`'s inputs, written out).
CHAIN = ("rng = np.random.default_rng(0)\n"
         "bonds = np.c_[np.arange(N - 1), np.arange(1, N)]\n"
         "system = vibra.System.from_springs(np.arange(N, dtype=float), 10.0 ** rng.uniform(-3, 3, N), bonds,\n"
         "                                   10.0 ** rng.uniform(-3, 3, N - 1))\n")
NETWORK = ("from vibra import networks\n"
           "rng = np.random.default_rng(0)\n"
           "side = (500 / 0.05) ** (1 / 3)\n"
           "system = networks.anm(rng.uniform(0.0, side, size=(500, 3)), cutoff=8.5)\n")


def _loaded_after(code: str) -> list[str]:
    """The modules of `HEAVY` a fresh interpreter holds after running `code`."""
    script = f"import json, sys\n{code}\nprint(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))\n"
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT)
    return list(json.loads(result.stdout.strip().splitlines()[-1]))


def test_vibra_help_loads_none_of_the_heavy_dependencies() -> None:
    code = ("from vibra.cli import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n")
    assert _loaded_after(code) == []


@pytest.mark.parametrize(("build", "request_"), [
    (CHAIN.replace("N", "2000"), "n_modes=10"),                     # issue 45: accurate-bisection, dstebz
    (CHAIN.replace("N", "2000"), "n_modes=10, vectors=False"),
    (CHAIN.replace("N", "300"), "vectors=False"),                   # every value, numpy certificates
    (NETWORK, "n_modes=26"),                                        # accurate-checked
    (NETWORK, "n_modes=26, accuracy='fast'"),                       # dense
])
def test_a_small_problems_first_call_loads_no_compiled_kernel(build: str, request_: str) -> None:
    """No numba (nor llvmlite, nor mpmath) on the first call of the issue's small problems: the
    topology is classified by numpy, and each compiled step below `compiled.COMPILED_FROM_S`
    takes its numpy / LAPACK counterpart."""
    code = f"import numpy as np\nimport vibra\n{build}system.modes({request_})\n"
    assert _loaded_after(code) == []


def test_a_kernel_loads_numba_on_its_first_call_and_binds_its_module() -> None:
    """Importing a kernel module loads no numba; its first call does, and the module's kernels
    (and `prange`, `HOST_FMA`) are then numba's own objects; the result is the bits of the same
    function run by Python (sums, products, quotients and square roots: IEEE either way)."""
    code = ("import numpy as np\n"
            "from vibra.solvers.accurate import count_kernels as kernel\n"
            "before = 'numba' in sys.modules\n"
            "a, b, tie = np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.25]), np.array([0.0, 1e-3, 7.0])\n"
            "d, e = kernel.walled_factor(a, b, tie)\n"
            "d0, e0 = kernel._walled.py_func(a, b, tie)\n"
            "print(before, 'numba' in sys.modules, type(kernel._walled).__module__.split('.')[0],\n"
            "      type(kernel.FMA).__name__, np.array_equal(d, d0) and np.array_equal(e, e0))\n")
    result = subprocess.run([sys.executable, "-c", "import sys\n" + code], capture_output=True, text=True,
                            check=True, cwd=ROOT)
    assert result.stdout.split() == ["False", "True", "numba", "bool", "True"]


def test_the_decision_is_by_size() -> None:
    assert compiled.compiled_pays(compiled.COMPILED_FROM_S)
    assert not compiled.compiled_pays(0.5 * compiled.COMPILED_FROM_S)
    assert not gk_bisection.compiled_bisection_pays(2000, 10)      # issue 45's chain: dstebz
    assert gk_bisection.compiled_bisection_pays(1_000_000, 20)     # a long chain: the kernel


@pytest.mark.parametrize("vectors", [False, True])
def test_both_bisection_routes_give_the_singular_values(vectors: bool) -> None:
    """The lowest 10 singular values of a 300-entry bidiagonal (entries 0.5..2): dstebz (the route
    `gk_bisection.golub_kahan_lowest` takes at this size) and the compiled bisection each within 8 ulps
    of the other and within 1e-13 of numpy's SVD (well conditioned: absolute accuracy suffices)."""
    rng = np.random.default_rng(7)
    d, e = rng.uniform(0.5, 2.0, 300), rng.uniform(0.5, 2.0, 300)
    truth = np.sort(np.linalg.svd(np.diag(d) + np.diag(e[:-1], 1), compute_uv=False))[:10]
    lapack = gk_bisection.golub_kahan_lowest(d, e[:-1], 0, 10, vectors=vectors)[0]
    kernel = gk_bisection.bidiagonal_values_by_bisection(d, e[:-1], 0, 10)
    assert np.all(np.abs(lapack - kernel) <= 8 * EPS * kernel)
    assert np.all(np.abs(kernel - truth) <= 1e-13 * truth)


@pytest.mark.parametrize("order", ["C", "F"])
def test_a_small_product_takes_scipy_with_the_same_bits(order: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """`products.times` below `compiled.COMPILED_FROM_S`: scipy's CSR product, bit for bit the
    kernel's (the same sums in the same order), in the kernel's memory order."""
    rng = np.random.default_rng(3)
    B = sp.random(400, 300, density=0.02, random_state=4, format="csr")
    B.data = rng.standard_normal(B.nnz) * 10.0 ** rng.uniform(-6, 6, B.nnz)
    V = np.asarray(rng.standard_normal((300, 7)), order=order)
    small = products.times(B, V)
    monkeypatch.setattr(products, "compiled_pays", lambda seconds: True)
    kernel = products.times(B, V)
    assert np.array_equal(small, kernel)
    assert small.flags.f_contiguous == kernel.flags.f_contiguous
