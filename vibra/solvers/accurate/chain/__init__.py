"""The accurate paths of a chain of springs (each spring joins neighbouring sites; any anchored to a wall).

- `bidiagonal`: accurate-bidiagonal, dqds / dbdsqr on a chain's bidiagonal, and its certificates
- `triplets`: the compiled certificates (numba), one singular triplet per value
- `lowest`: accurate-bisection, the lowest modes by Golub-Kahan bisection
- `walled`: accurate-walled, a chain with springs to a wall inside it, values certified by counts
- `sturm_counts`: Sturm counts of a chain's spring form, for values its triplets cannot bound
"""
