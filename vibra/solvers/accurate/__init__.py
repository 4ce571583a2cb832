"""The accurate solver paths: frequencies of K = B^T W B to high relative accuracy, from the springs.

- `springs`: the accurate paths of any spring system (-checked, -ritz, -rayleigh, -jacobi)
- `spring_ritz`: spring-space Rayleigh-Ritz per cluster, residual bounds, B~'s own rounding
- `golub_kahan`: B~'s singular triplets by Golub-Kahan inverse iteration (Kato-Temple bounds)
- `dd`: double-double arithmetic on arrays: sums, LU and its solves
- `rounding`: error-free arithmetic behind the chain bounds (entry roundings, scalings)
- `chain`: the paths of a chain of springs; `ring`: those of a ring (a chain closed by one spring)
"""
