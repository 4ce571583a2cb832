"""Symmetry-reduced finite differences of molecules: displace only what the point group does not give.

A symmetry operation g of the molecule (rotation or reflection R about the centre of mass, atom
permutation p: atom i lands on p(i)) maps the geometry onto itself, and any calculator's forces
with it: F_p(i)(g x) = R F_i(x). Differentiating along a displacement e of atom s gives the rows of
the other atoms of its orbit: the derivative along R e of atom p(s) is the derivative along e of
atom s, rotated (R v_i for the force on atom i, moved to p(i); R mu for the dipole; R alpha R^T for
the polarisability). So the finite difference displaces

- one atom of each orbit of the permutations (the lowest index), and
- of that atom, only the Cartesian directions its site symmetry (the operations that keep it in
  place) does not map onto the others, tried in the order x, y, z, as phonopy does for crystals
  (the carbon of CH4: x alone; C3 and C2 turn it into y and z);

and the rows of every other degree of freedom are rebuilt from these, one difference quotient
(each step multiple) at a time, so that the Richardson truncation estimate of a rebuilt row is
that of its source rows carried through the same linear map. A site's missing directions are a
least-squares solution over all its operations (exact for exact operations).

When to trust the operations
----------------------------
`vibra.molecules.symmetry.point_group` finds the group within 0.01 Angstrom and reports how far
the worst operation misses an atom (`PointGroup.deviation`); the geometry is not symmetrised. A
rebuilt row is then the derivative at a geometry up to `deviation` away from the true one: an
error ~ deviation |E'''| against the truncation error the central difference already accepts,
(m h)^2 |E''''| / 6. With |E''''| ~ |E'''| / L, L ~ 1 Angstrom the length over which bond
anharmonicity changes (Morse: 1/a ~ 0.5 Angstrom), the symmetry error stays below the
truncation error while deviation <= h^2 / (6 Angstrom) (1.7e-5 Angstrom at h = 0.01): the
tolerance `symmetry_tolerance`. Beyond it, for a periodic cell (the images need not share the
molecule's symmetry) and where atoms of one orbit differ in an ASE array (tags, initial charges
or magnetic moments), the full plan runs and the result says why (`Reduction.note`). Within it,
the miss is not assumed away: deviation times the largest curvature of the sampled values seen
along a displaced direction, |v(+h) + v(-h) - 2 v(0)| / h^2, is added to the error estimate of
every entry (`Reduction.geometry_error`). Measured on NH3 and benzene from ASE's g2 set
(deviation 1e-6 and 2e-7 Angstrom), EMT and the valence force field: every entry within 1.15 times
the summed estimates of the reduced and the full run (without this term: 7 times).

Groups whose operations map Cartesian axes onto axes (Td, C2v, D2h in their frames) rebuild the
same quotients the full plan computes; others (C3, C6, C8) rotate a direction into a combination
of axes, which samples other fourth derivatives: the rebuilt rows then differ at the truncation
level, within the Richardson estimates. The calculator must turn with the molecule (any physical
one does; a DFT integration grid only to its grid error).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from ase import Atoms

    from vibra.molecules.displacements import Displacement

__all__ = ["Reduction", "reduction", "symmetry_tolerance"]

_ANHARMONIC_LENGTH = 1.0   # Angstrom: L in the tolerance h^2 / (6 L) (module notes)


def symmetry_tolerance(step: float) -> float:
    """Largest miss of a symmetry operation (Angstrom) that a finite difference of step `step` tolerates."""
    return step * step / (6.0 * _ANHARMONIC_LENGTH)


@dataclass(frozen=True, eq=False)
class Reduction:
    """Which degrees of freedom a finite difference displaces, and how to rebuild the rest.

    Attributes
    ----------
    group : str
        Point group used (``"C1"`` when none).
    dofs : tuple of int
        Displaced degrees of freedom, 3 atom + axis, ascending (every one when not reduced).
    n_dof : int
        3 n_atoms.
    note : str
        What was done, in words: the group and the atoms and directions displaced, or why not.
    deviation : float
        Largest miss of an operation, Angstrom (`PointGroup.deviation`; 0 when not reduced).
    operations, permutations, source
        The group's matrices and permutations; ``source[a] = (s, g)``: atom a is p_g(s) for its
        orbit's representative s (None when not reduced).
    site : dict
        For each representative s, (operation indices of its site group, displaced axes).
    """

    group: str
    dofs: tuple[int, ...]
    n_dof: int
    note: str
    deviation: float = 0.0
    operations: NDArray[np.float64] | None = None
    permutations: NDArray[np.intp] | None = None
    source: tuple[tuple[int, int], ...] = ()
    site: dict[int, tuple[tuple[int, ...], tuple[int, ...]]] | None = None

    @property
    def reduced(self) -> bool:
        """Whether fewer degrees of freedom than all are displaced."""
        return len(self.dofs) < self.n_dof

    def complete(self, quotient: NDArray[np.float64], kind: str) -> NDArray[np.float64]:
        """Fill the rows of `quotient` (n_dof, width) not displaced, from the displaced ones.

        `kind` says how a row transforms: ``"forces"`` (width 3 n_atoms), ``"dipole"`` (3) or
        ``"polarizability"`` (9). Rows of displaced dofs are left as they are.
        """
        if not self.reduced:
            return quotient
        assert self.operations is not None and self.permutations is not None and self.site is not None
        out = np.array(quotient, dtype=float)
        for s, (ops, axes) in self.site.items():        # the representative's missing directions
            if len(axes) == 3:
                continue
            lhs, rhs = [], []
            for g in ops:
                r = self.operations[g]
                for e in axes:
                    lhs.append(r[:, e])                   # sum_c (R e)_c M_s[c] = T_g(M_s[e])
                    rhs.append(self._transform(g, out[3 * s + e], kind))
            solution = np.linalg.lstsq(np.array(lhs), np.array(rhs), rcond=None)[0]
            missing = [c for c in range(3) if c not in axes]
            out[[3 * s + c for c in missing]] = solution[missing]
        for a, (s, g) in enumerate(self.source):        # the orbit: M_a = R T_g(M_s)
            if a == s:
                continue
            moved = np.array([self._transform(g, out[3 * s + e], kind) for e in range(3)])
            out[3 * a:3 * a + 3] = self.operations[g] @ moved
        return out

    def geometry_error(self, samples: Sequence[NDArray[np.float64]], plan: Sequence[Displacement],
                       h: float) -> float:
        """The error the operations' miss adds to every rebuilt entry: `deviation` times the
        largest second derivative of the sampled values seen along a displaced dof,
        |v(+h) + v(-h) - 2 v(0)| / h^2 (a Hessian row moves by about the third derivative of the
        energy times delta when the geometry moves by delta). 0 when not reduced."""
        if not self.reduced or self.deviation == 0.0:
            return 0.0
        curvature = max((float(np.abs(samples[p.index] + samples[m.index] - 2.0 * samples[0]).max())
                         for p, m in zip(plan[1::2], plan[2::2]) if p.multiple == 1), default=0.0)
        return self.deviation * curvature / (h * h)

    def _transform(self, g: int, row: NDArray[np.float64], kind: str) -> NDArray[np.float64]:
        assert self.operations is not None and self.permutations is not None
        r = self.operations[g]
        if kind == "dipole":
            return r @ row
        if kind == "polarizability":
            return (r @ row.reshape(3, 3) @ r.T).ravel()
        field = row.reshape(-1, 3)
        moved = np.empty_like(field)
        moved[self.permutations[g]] = field @ r.T
        return moved.ravel()


def _full(n_atoms: int, note: str, group: str = "C1") -> Reduction:
    return Reduction(group=group, dofs=tuple(range(3 * n_atoms)), n_dof=3 * n_atoms, note=note)


def reduction(atoms: Atoms, step: float, symmetry: bool) -> Reduction:
    """The degrees of freedom to displace for `atoms` (module notes), or all of them with the reason."""
    from vibra.molecules.symmetry import point_group

    n = len(atoms)
    if not symmetry:
        return _full(n, "symmetry=False: every Cartesian displacement")
    if n < 2:
        return _full(n, "one atom: every Cartesian displacement")
    if bool(np.any(atoms.pbc)):
        return _full(n, "periodic cell (its images need not share the molecule's symmetry): "
                        "every Cartesian displacement")
    try:
        group = point_group(atoms)
    except RuntimeError as error:
        return _full(n, f"no point group ({error}): every Cartesian displacement")
    if group.n_operations == 1:
        return _full(n, "point group C1: every Cartesian displacement")
    allowed = symmetry_tolerance(step)
    if group.deviation > allowed:
        return _full(n, f"geometry deviates from {group.name} by {group.deviation:.3g} Angstrom, more than the "
                        f"{allowed:.3g} Angstrom that step={step:g} tolerates (h^2 / 6 Angstrom); every Cartesian "
                        "displacement (symmetrise the geometry to use the symmetry)", group.name)
    perms = np.asarray(group.permutations)
    for key, values in atoms.arrays.items():             # tags, charges, magnetic moments: must map too
        if key not in ("positions", "momenta") and any(not np.array_equal(values[p], values) for p in perms):
            return _full(n, f"atoms of one orbit of {group.name} differ in {key!r}: every Cartesian displacement",
                         group.name)
    source: list[tuple[int, int]] = [(-1, -1)] * n
    for a in range(n):                                   # representatives in index order
        if source[a][0] >= 0:
            continue
        for g in range(len(perms)):
            b = int(perms[g, a])
            if source[b][0] < 0:
                source[b] = (a, g)
    site: dict[int, tuple[tuple[int, ...], tuple[int, ...]]] = {}
    dofs: list[int] = []
    for s in sorted({s for s, _ in source}):
        ops = tuple(int(g) for g in np.flatnonzero(perms[:, s] == s))
        axes: list[int] = []
        for e in range(3):                               # add an axis only if its images widen the span
            if _span(group.operations, ops, axes + [e]) > _span(group.operations, ops, axes):
                axes.append(e)
        site[s] = (ops, tuple(axes))
        dofs.extend(3 * s + e for e in axes)
    shown = ", ".join(f"{atoms.get_chemical_symbols()[s]}{s} ({''.join('xyz'[e] for e in site[s][1])})"
                      for s in site)
    note = (f"point group {group.name} ({group.n_operations} operations, deviation {group.deviation:.2g} "
            f"Angstrom): displaced {shown}; {len(dofs)} of {3 * n} degrees of freedom")
    return Reduction(group=group.name, dofs=tuple(sorted(dofs)), n_dof=3 * n, note=note, deviation=group.deviation,
                     operations=np.asarray(group.operations), permutations=perms, source=tuple(source), site=site)


def _span(operations: NDArray[np.float64], ops: tuple[int, ...], axes: list[int]) -> int:
    """Dimension of the span of R e over the site operations and the chosen axes."""
    if not axes:
        return 0
    # singular values of unit images below 0.1 are directions the operations (built to the
    # geometry's accuracy, ~1e-6) only graze: not a span to solve in (it would amplify their error)
    return int(np.linalg.matrix_rank(np.array([operations[g][:, e] for g in ops for e in axes]), tol=0.1))
