"""Building the kernels' ahead-of-time copy (`vibra.solvers.aot`): ``python -m vibra.solvers.aot_build``.

`build` imports the modules that declare kernels ``aot=True`` (`aot.KERNEL_MODULES`), runs each
declared kernel through numba on small inputs of the types real calls pass (`exercise`: the
spring form's counts of a chain, a ring's pencil counts, a chain's triplet figures, the
spring-space products in both memory orders, through the functions the solvers call), and compiles, with `numba.pycc`, every signature numba compiled for
them, each under its own name with its argument types in ``manifest.json``. The options are the
kernels' own (numpy's error model, no fast-math: `Flags` patched for the export, which numba's
compiler builds with its defaults) and the CPU numba's JIT targets (the host's name and
features, or ``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES``: the AOT code generator would otherwise
take the name's features, which a virtual machine may mask).

The copy is written into a scratch folder beside its place, made readable to every user of a
shared cache, and renamed into place (a reader sees a whole copy or none); a copy already there
is renamed aside first and removed after. ``--background`` (what `aot.start_background_build`
runs) lowers the process's priority, removes its lock when done, and, when the build fails,
leaves ``<key>.failed`` with the error, so that no later process retries it; a foreground build
removes that note when it succeeds.
"""

from __future__ import annotations

import importlib
import json
import os
import shutil
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp

import vibra.solvers.aot as aot
import vibra.solvers.compiled as compiled

__all__ = ["build", "exercise", "main"]


def exercise() -> None:
    """Each ``aot=True`` kernel run once through numba, with the argument types its callers pass."""
    from vibra.solvers.accurate.chain.sturm_counts import chain_form
    from vibra.solvers.accurate.chain.triplets import triplet_figures
    from vibra.solvers.accurate.products import SCIPY_PRODUCT_S, times
    from vibra.solvers.accurate.ring.counts import ring_pencil
    from vibra.solvers.accurate.ring.pencil_counts import PencilCounts

    def springs(n: int, closed: bool, per_row: int = 2) -> sp.csr_matrix:
        """n sites joined i to i + 1 (closed: and n - 1 to 0), `per_row` entries a row (+-1 for springs)."""
        m = n if closed else n - 1
        values = np.tile([-1.0, 1.0], m) if per_row == 2 else np.ones(per_row * m)
        columns = (np.arange(m)[:, None] + np.arange(per_row)) % n
        return sp.csr_matrix((values, columns.ravel(), np.arange(0, per_row * m + 1, per_row)), shape=(m, n))

    n, x = 12, np.linspace(0.05, 3.9, 16)
    form = chain_form(springs(n, closed=False), np.ones(n - 1), np.ones(n))  # a chain's spring-form counts
    pencil = ring_pencil(springs(n, closed=True), np.ones(n), np.ones(n))    # a ring's pencil counts
    assert form is not None and pencil is not None
    form.counts(x)
    PencilCounts(pencil).counts(x)
    s = 6  # a chain's triplet figures
    triplet_figures(np.full(s, 2.0), np.full(s - 1, 0.5), np.array([0.3, 1.1]), np.ones(2 * s), np.zeros(s),
                    np.zeros(s), np.zeros(s), np.zeros(s))
    # B~ V by the compiled loops, both memory orders: 8 entries a row x 8 columns, twice the work from
    # which `products.times` takes them (`compiled.COMPILED_FROM_S`), whatever the rounding
    rows = int(np.ceil(compiled.COMPILED_FROM_S / (SCIPY_PRODUCT_S * 8 * 4))) + 1
    B, V = springs(rows, closed=True, per_row=8), np.ones((rows, 8))
    times(B, V)
    times(B, np.asfortranarray(V))


def _argument(t: Any) -> list[Any]:
    from numba.core import types
    from numba.np.numpy_support import as_dtype

    if isinstance(t, types.Array):
        return ["array", as_dtype(t.dtype).str, int(t.ndim), t.layout, not bool(t.mutable)]
    if isinstance(t, types.Boolean):
        return ["bool"]
    if isinstance(t, types.Integer) and t.bitwidth == 64 and t.signed:
        return ["int64"]
    if isinstance(t, types.Float) and t.bitwidth == 64:
        return ["float64"]
    raise TypeError(f"no ahead-of-time export for an argument of type {t}")


def build(target: Path | None = None, *, quiet: bool = True) -> Path:
    """Compile every ``aot=True`` kernel ahead of time into `target` (default: this key's place,
    `aot.folder`); returns it."""
    import numba.core.codegen as codegen
    import numba.pycc.compiler as pycc_compiler
    from numba.pycc import CC

    aot.mark_building()
    target = aot.folder() if target is None else Path(target)
    for name in aot.KERNEL_MODULES:
        importlib.import_module(name)
    exercise()
    kernels = list(compiled.AOT_KERNELS)
    options = {"error_model": "numpy", "fastmath": False}  # the kernels' own (`count_kernels.kernel_jit`)
    for kernel in kernels:
        bad = {k: v for k, v in options.items() if kernel.options.get(k) != v}
        if bad:
            raise ValueError(f"{kernel!r} is declared aot=True without the options {bad} its export compiles with")

    class _Flags(pycc_compiler.Flags):  # type: ignore[misc,name-defined]
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.error_model = "numpy"

    saved = pycc_compiler.Flags, codegen.AOTCPUCodegen._customize_tm_features
    pycc_compiler.Flags = _Flags
    codegen.AOTCPUCodegen._customize_tm_features = codegen.CPUCodegen._get_host_cpu_features  # the JIT's features
    try:
        return _compile(CC, kernels, target, quiet)
    finally:
        pycc_compiler.Flags, codegen.AOTCPUCodegen._customize_tm_features = saved


def _compile(CC: Any, kernels: list[Any], target: Path, quiet: bool) -> Path:
    cc = CC(aot.MODULE_NAME)
    cc.target_cpu = "host"  # numba's JIT's CPU name (NUMBA_CPU_NAME where set)
    cc.verbose = not quiet
    manifest: dict[str, list[dict[str, Any]]] = {}
    for kernel in kernels:
        module_name, name = kernel.py_func.__module__, kernel.py_func.__name__
        signatures = list(kernel.resolve().nopython_signatures)
        if not signatures:
            raise RuntimeError(f"{module_name}.{name} is declared aot=True but exercise() never ran it")
        for i, signature in enumerate(signatures):
            symbol = f"{module_name.rsplit('.', 1)[-1]}__{name.strip('_')}__{i}"
            cc.export(symbol, signature)(kernel.py_func)
            manifest.setdefault(f"{module_name}.{name}", []).append(
                {"symbol": symbol, "args": [_argument(t) for t in signature.args]})
    target.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=".build-", dir=target.parent))
    try:
        cc.output_dir = str(scratch)
        cc.compile()
        library = scratch / aot.library_name()
        (scratch / "manifest.json").write_text(json.dumps({"key": aot.key(), "sha256": aot.sha256(library),
                                                           "kernels": manifest}, indent=1), encoding="utf-8")
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(scratch, 0o777 & ~mask)  # mkdtemp's 0700 would hide it from the other users of a shared cache
        _install(scratch, target)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return target


def _install(scratch: Path, target: Path) -> None:
    """Rename `scratch` into `target`; a copy already there is renamed aside first, then removed."""
    aside = None
    if target.exists():
        aside = target.with_name(f".old-{target.name}-{os.getpid()}")
        try:
            os.rename(target, aside)
        except OSError:
            aside = None
    try:
        os.rename(scratch, target)
    except OSError:  # another build put its copy there meanwhile: keep that one
        pass
    if aside is not None:
        shutil.rmtree(aside, ignore_errors=True)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m vibra.solvers.aot_build [--verbose] [--background --lock FILE]``."""
    args = list(sys.argv[1:] if argv is None else argv)
    background = "--background" in args
    lock = Path(args[args.index("--lock") + 1]) if "--lock" in args else None
    if background and hasattr(os, "nice"):
        os.nice(10)  # a background build yields the cores to the user's own work
    if not aot.enabled():
        print("ahead-of-time kernels are off here (Linux only, a cache folder needed; VIBRA_AOT=0 turns them off)")
        return 0
    failed = aot.folder().with_name(aot.key() + ".failed")
    start = time.perf_counter()
    try:
        where = build(quiet="--verbose" not in args)
    except Exception:  # a build that cannot work here (no C compiler, no setuptools): said once, not retried
        if background:
            try:
                failed.parent.mkdir(parents=True, exist_ok=True)
                failed.write_text(traceback.format_exc(), encoding="utf-8")
            except OSError:
                pass  # (an unwritable cache: no build can be started there either)
            return 1
        raise
    finally:
        if lock is not None:
            lock.unlink(missing_ok=True)
    failed.unlink(missing_ok=True)
    if not background:
        print(f"built {where} in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
