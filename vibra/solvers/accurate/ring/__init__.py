"""The accurate paths of a ring (a chain of springs closed by one spring).

- `counts`: a ring's pencil and its Sturm counts in double-double (certified bounds)
- `values`: accurate-ring, every frequency (or the lowest), roots certified by counts
- `kernel`: the compiled loops (numba): the spring form's pivots, roots and counts
"""
