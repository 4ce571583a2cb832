"""Mechanics in generalised coordinates: builders of `GeneralizedSystem` and exact motions.

- `linearization`: `linearize`, small oscillations of a sympy Lagrangian about an equilibrium
- `lagrangian`: T, V or L (or sympy mechanics) -> M, G, C, K
- `rigid`: inertia tensors, Huygens' theorem, compound pendulums, bodies on springs
- `gyroscopic`: a charge in a magnetic field, the Foucault pendulum, a spinning wheel
- `pendulum`: the simple pendulum, exact (up to pi) versus harmonic
"""
