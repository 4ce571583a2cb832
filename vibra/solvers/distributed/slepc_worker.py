"""The MPI side of the ``slepc`` path: run by path, as ``mpiexec -n R python3 slepc_worker.py FOLDER``.

A standalone program (it imports nothing from vibra: it runs under the Python that has
petsc4py and slepc4py, Debian's ``/usr/bin/python3`` with ``python3-slepc4py``, not vibra's
environment). Its only inputs are the files `vibra.solvers.distributed.slepc` wrote in FOLDER:

- ``request.json``: n, n_modes, ranks, tolerance, the shift, ||K~||_inf;
- ``indptr.npy``, ``indices.npy``, ``data.npy``: K~ = M^-1/2 K M^-1/2 in CSR, float64 / int64.

Each rank memory-maps the three ``.npy`` files and reads only its own block of rows (PETSc's
default split of n rows over R ranks), so no rank holds the whole matrix. K~ becomes one
distributed PETSc AIJ matrix; SLEPc's Krylov-Schur (EPS, Hermitian) with shift-and-invert at
the shift sigma < 0 (below the spectrum: a free network's K~ is singular) and the shifted
system factored by MUMPS (a parallel sparse LDL^T). The factor's inertia is read (MUMPS
ICNTL(13) = 1 so that it is exact in parallel): if K~ has eigenvalues below sigma, sigma moves
below Gershgorin's bound and the solve runs again, as the one-process sparse path does.

Output, in FOLDER, each file written under a temporary name and renamed (rank 0 renames after
every rank wrote): ``values.npy`` (k,), ``vectors.npy`` (n, k) (each rank writes its own rows
into one memory-mapped file), ``result.json`` (residuals, timings, iterations, shift, inertia);
or ``error.json`` with one line saying what failed. The exit status is 0 only with a result.
"""

from __future__ import annotations

import json
import os
import sys
import time

import numpy as np


#: Steps of inverse iteration applied to each converged vector before it is written (one: measured
#: on ubiquitin's 1,806-dof ANM, residuals 9e-14 ||K~|| without, 6e-15 with; more would amplify
#: the solves' rounding along the zero modes by (lambda - sigma) / |sigma| a step)
PURIFY_STEPS = 1


def _split(n: int, size: int, rank: int) -> tuple[int, int]:
    """PETSc's default ownership of n rows on `size` ranks (PetscSplitOwnership): [start, end)."""
    base, extra = divmod(n, size)
    start = rank * base + min(rank, extra)
    return start, start + base + (1 if rank < extra else 0)


def _write_json(path: str, content: dict) -> None:
    temporary = path + ".part"
    with open(temporary, "w", encoding="utf-8") as handle:
        json.dump(content, handle)
    os.replace(temporary, path)


def main(folder: str) -> int:
    import petsc4py
    petsc4py.init([sys.argv[0]])
    from petsc4py import PETSc
    import slepc4py
    slepc4py.init([sys.argv[0]])
    from slepc4py import SLEPc

    comm = PETSc.COMM_WORLD
    rank, size = comm.getRank(), comm.getSize()
    with open(os.path.join(folder, "request.json"), encoding="utf-8") as handle:
        request = json.load(handle)
    n, k, wanted_ranks = int(request["n"]), int(request["n_modes"]), int(request["ranks"])

    def fail(message: str) -> int:
        if rank == 0:
            _write_json(os.path.join(folder, "error.json"), {"error": message})
        return 2

    if size != wanted_ranks:
        # R processes that each see one rank: mpiexec is not the MPI that PETSc was built with
        return fail(f"mpiexec started {wanted_ranks} processes but PETSc sees {size} rank(s): the mpiexec "
                    "on the path is not the MPI that petsc4py was built with (Debian's: OpenMPI, mpiexec.openmpi)")
    clock = {"start": time.perf_counter()}

    # ---- each rank its own block of rows, from the memory-mapped CSR arrays
    start, end = _split(n, size, rank)
    indptr = np.load(os.path.join(folder, "indptr.npy"), mmap_mode="r")
    indices = np.load(os.path.join(folder, "indices.npy"), mmap_mode="r")
    data = np.load(os.path.join(folder, "data.npy"), mmap_mode="r")
    rows = np.asarray(indptr[start:end + 1], dtype=np.int64)
    first, last = int(rows[0]), int(rows[-1])
    local_indptr = (rows - first).astype(PETSc.IntType)
    local_indices = np.asarray(indices[first:last]).astype(PETSc.IntType)
    local_data = np.asarray(data[first:last], dtype=PETSc.ScalarType)
    A = PETSc.Mat().createAIJ(size=((end - start, n), (end - start, n)),
                              csr=(local_indptr, local_indices, local_data), comm=comm)
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    A.assemble()
    del indptr, indices, data
    clock["assembled"] = time.perf_counter()

    norm = float(request["norm"])
    sigma = float(request["sigma"])
    tolerance = float(request["tolerance"])
    ncv = int(request["ncv"])
    options = PETSc.Options()

    def mumps_inertia(prefix: str) -> None:
        options[prefix + "mat_mumps_icntl_13"] = 1  # MUMPS factors the root node itself: the inertia exact in parallel
        options[prefix + "mat_mumps_icntl_24"] = 1  # null pivots detected (PETSc reads the inertia only then),
        options[prefix + "mat_mumps_cntl_3"] = -1e-300  # but none replaced: only an exact 0 counts as null

    def solver(shift: float, nev: int, deflation: list) -> tuple:
        """Krylov-Schur for the nev eigenvalues nearest `shift`, shift-and-invert by MUMPS's
        LDL^T, the vectors of `deflation` projected out; set up (factored): (eps, its factor)."""
        eps = SLEPc.EPS().create(comm)
        eps.setOperators(A)
        eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
        eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
        eps.setDimensions(nev=nev, ncv=min(n, max(ncv, 2 * nev + 1)))
        eps.setTolerances(tol=tolerance, max_it=int(request["max_it"]))
        eps.setTarget(shift)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        if deflation:
            eps.setDeflationSpace(deflation)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        ksp = st.getKSP()
        ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = ksp.getPC()
        pc.setType(PETSc.PC.Type.CHOLESKY)
        pc.setFactorSolverType("mumps")
        mumps_inertia(ksp.getOptionsPrefix() or "")  # (SLEPc's "st_": the factor reads its options under it)
        eps.setFromOptions()  # (PETSC_OPTIONS may tune the run: -eps_ncv, -st_mat_mumps_icntl_14, ...)
        eps.setUp()
        return eps, pc.getFactorMatrix()

    def count_below(tau: float) -> int:
        """Eigenvalues of K~ below tau (Sylvester: the negative and zero pivots of K~ - tau I's LDL^T)."""
        shifted = A.copy()
        shifted.shift(-tau)
        pc = PETSc.PC().create(comm)
        pc.setOptionsPrefix("vibra_count_")
        mumps_inertia("vibra_count_")
        pc.setOperators(shifted)
        pc.setType(PETSc.PC.Type.CHOLESKY)
        pc.setFactorSolverType("mumps")
        pc.setUp()
        negative, zero, _ = pc.getFactorMatrix().getInertia()
        pc.destroy()
        shifted.destroy()
        return int(negative) + int(zero)

    def collect(eps) -> list:  # type: ignore[no-untyped-def]
        pairs = []
        for i in range(eps.getConverged()):
            vector = A.createVecRight()
            value = eps.getEigenpair(i, vector).real
            pairs.append((value, vector, eps.computeError(i, SLEPc.EPS.ErrorType.ABSOLUTE)))
        return pairs

    eps, factor = solver(sigma, k, [])
    negative, zero, _ = factor.getInertia()
    inertia = [int(negative), int(zero)]
    if negative or zero:
        # K~ has eigenvalues at or below the shift (an indefinite K): below Gershgorin's bound instead
        eps.destroy()
        sigma = min(float(request["gershgorin_lower"]), 0.0) - 1e-3 * norm
        eps, factor = solver(sigma, k, [])
        negative, zero, _ = factor.getInertia()
        if negative or zero:
            return fail(f"K~ - sigma I is still not positive definite at sigma = {sigma:.3g} "
                        f"({negative} negative, {zero} zero pivots)")
        inertia = [int(negative), int(zero)]
    clock["factored"] = time.perf_counter()
    eps.solve()
    restarts = eps.getIterationNumber()
    clock["solved"] = time.perf_counter()
    pairs = collect(eps)
    # Every eigenvalue below the k-th found? A Krylov space can miss a partner of a multiple
    # eigenvalue; Sylvester's count of K~ - tau I (tau just above the k-th, below the next found)
    # says how many lie below tau, and each one missing is sought again with the found vectors
    # deflated (SLEPc's deflation space), up to three times
    counts = []
    margin = 1e-8 * norm  # far above each value's error (~1e-14 ||K~||), below any gap that matters
    for _ in range(4):
        pairs.sort(key=lambda pair: pair[0])
        if len(pairs) < k:
            return fail(f"SLEPc Krylov-Schur converged {len(pairs)} of {k} pairs in {restarts} restarts "
                        f"(tolerance {tolerance:g}, ncv {ncv})")
        value_k = pairs[k - 1][0]
        following = pairs[k][0] if len(pairs) > k else None
        apart = following is not None and following - value_k > 2 * margin
        tau = 0.5 * (value_k + following) if apart else value_k + margin  # type: ignore[operator]
        below, have = count_below(tau), sum(1 for pair in pairs if pair[0] < tau)
        counts.append([tau, below, have])
        if below <= have:
            break
        more, _ = solver(sigma, below - have, [pair[1] for pair in pairs])
        more.solve()
        pairs += collect(more)
        more.destroy()
    else:
        return fail(f"SLEPc missed {below - have} eigenvalues below {tau:.6g} (Sylvester's count) after three "
                    "deflated solves")
    clock["counted"] = time.perf_counter()
    converged = len(pairs)
    pairs = pairs[:k]

    values = np.empty(k)
    residuals = np.empty(k)
    vectors_path = os.path.join(folder, "vectors.npy")
    partial_path = vectors_path + ".part"
    if rank == 0:
        np.lib.format.open_memmap(partial_path, mode="w+", dtype=np.float64, shape=(n, k)).flush()
    comm.barrier()
    block = np.lib.format.open_memmap(partial_path, mode="r+")
    y = A.createVecRight()
    st = eps.getST()
    for i, (value, x, residual) in enumerate(pairs):
        values[i], residuals[i] = value, residual
        # one step of inverse iteration, y = (K~ - sigma)^-1 x: Krylov-Schur's test is on the
        # transformed operator, blind to what its inexact solves leave along the highest modes
        # (measured: ~1e-8 ||K~|| residuals whatever the tolerance); the step divides those by
        # (lambda_max - sigma) / (lambda - sigma), and vibra's Rayleigh-Ritz step follows
        for _ in range(PURIFY_STEPS):
            st.apply(x, y)
            y.scale(1.0 / y.norm())
            x, y = y, x
        block[start:end, i] = x.getArray(readonly=True)
    block.flush()
    del block
    comm.barrier()
    clock["written"] = time.perf_counter()
    if rank == 0:
        order = np.argsort(values, kind="stable")
        if np.any(order != np.arange(k)):  # (SLEPc returns them nearest the target first: ascending here)
            vectors = np.load(partial_path, mmap_mode="r+")
            vectors[:] = vectors[:, order]
            vectors.flush()
            del vectors
            values, residuals = values[order], residuals[order]
        os.replace(partial_path, vectors_path)
        with open(os.path.join(folder, "values.npy.part"), "wb") as handle:
            np.save(handle, values)
        os.replace(os.path.join(folder, "values.npy.part"), os.path.join(folder, "values.npy"))
        stages = ("assembled", "factored", "solved", "counted", "written")
        timings = {name: clock[name] - clock["start"] for name in stages}
        _write_json(os.path.join(folder, "result.json"), {
            "ranks": size, "sigma": sigma, "inertia": inertia, "converged": int(converged), "counts": counts,
            "restarts": int(restarts), "residuals": residuals.tolist(), "seconds": timings,
            "petsc": ".".join(map(str, PETSc.Sys.getVersion())), "slepc": ".".join(map(str, SLEPc.Sys.getVersion())),
        })
    eps.destroy()
    A.destroy()
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.stderr.write("usage: mpiexec -n R python3 slepc_worker.py FOLDER\n")
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
