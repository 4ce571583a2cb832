"""The accurate solver paths: frequencies of K = B^T W B to high relative accuracy, from the springs.

- `springs`: the accurate paths of any spring system (-checked, -ritz, -rayleigh, -jacobi)
- `spring_ritz`: spring-space Rayleigh-Ritz per cluster, residual bounds, B~'s own rounding
- `golub_kahan`: B~'s singular triplets by Golub-Kahan inverse iteration (Kato-Temple bounds)
- `dd`: double-double arithmetic on arrays: sums, LU and its solves
- `rounding`: error-free arithmetic behind the chain bounds (entry roundings, scalings)
- `count_kernels`: the compiled loops (numba) both chains and rings use: scalar double-double, the spring
  form's counts and pivot roots, a chain's counts, the cut chain's factor
- `counting`: certifying values by those counts (the ladder of brackets, multisection, widths)
- `gk_bisection`: a bidiagonal's singular values by Golub-Kahan bisection (compiled, or dstebz)
- `products`: compiled products B~ V and B~^T E (spring-space Rayleigh-Ritz), and a triple-double one
- `chain`: the paths of a chain of springs; `ring`: those of a ring (a chain closed by one spring);
  each imports from the modules above it, never from the other
"""
