"""The standard solver paths: eigenvalues of K~ to an absolute error ~ eps ||K~||.

- `lapack`: dense, tridiagonal and banded LAPACK eigensolvers
- `sparse`: shift-invert for a few modes or a band (the factor, the shift, the probe)
- `ordering`: nested-dissection ordering (METIS through pymetis) for SuperLU
- `pardiso`: the optional MKL PARDISO Cholesky (``vibra[pardiso]``)
- `krylov`: block Krylov iteration (block Arnoldi, full reorthogonalisation)
- `gpu`: ``device="gpu"``, the dense all-modes solve with CuPy (cuSOLVER syevd), the iterative path's GPU memory
- `iterative`: LOBPCG with a multigrid preconditioner for the lowest modes of large networks (CPU or GPU)
- `lobpcg`: the block LOBPCG itself, on numpy or CuPy arrays
- `hermitian`: stacked complex Hermitian solves of the crystals' D(q) (called directly, not a registry path)
"""
