"""The accurate paths of a ring (a chain of springs closed by one spring).

- `counts`: a ring's pencil and its Sturm counts in double-double (certified bounds)
- `values`: accurate-ring, every frequency (or the lowest), roots certified by counts
- `counted`: accurate-ring at "high", a standard solver's values each bracketed by two counts
- `pencil_counts`: the compiled counts of K - x M, for the values its perturbation leaves sharp
"""
