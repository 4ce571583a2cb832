"""Eigenproblems with more structure than K~ d = omega^2 d.

- `pencil`: K x = omega^2 M x with a full, possibly ill-conditioned mass matrix (`vibra.modes.pencil_modes` calls it)
- `equilibrated`: its solver, the pencil paths' runner (no `Modes`: the registry imports it)
- `first_order`: the first-order forms of M q'' + (G + C) q' + K q = 0 and their eigensolvers (the
  quadratic paths' runners call them)
- `quadratic`: gyroscopic and damped modes, M q'' + (G + C) q' + K q = 0 (`QuadraticModes`)
"""
