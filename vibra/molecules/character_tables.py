"""Character tables of the molecular point groups, for the operations of a group in its standard frame.

A table is built for the list of 3x3 operations that `vibra.molecules.point_group` found, in
the standard frame (z the principal axis, x the secondary axis: see `symmetry.py`), so its
characters come one per operation, not one per class.

- Axial groups (Cn, Cnv, Cnh, Dn, Dnd, Dnh, S2n, Cs, Ci, C1): the irreducible representations
  are found from basis functions. Each candidate z^p Re/Im (x + i y)^m (p = 0, 1), and each pair
  z^p (Re, Im)(x + i y)^k, is transformed by every operation, f(R^T r), and its matrix fitted on
  sample points; a closed candidate whose characters are irreducible is kept. A complex-conjugate
  pair of 1-D representations (Cn, Cnh, S2n, T, Th) is kept as one real E, as textbook tables
  print it. The Mulliken label then follows from the characters: A/B from the principal rotation
  (S2n in S4, S8, D2d, D4d, ...), subscripts 1/2 from C2'(x) or else sigma_v(xz), primes from
  sigma_h, g/u from i, E_k from the principal character 2 cos(2 pi k / n); D2 and D2h use
  B1/B2/B3 for the z/y/x axes.
- Cubic and icosahedral groups: the textbook tables of T, O and I (Cotton, "Chemical Applications
  of Group Theory", appendix IIA) typed in, with each operation's class recognised from its
  rotation angle (and, for O's two classes of C2, whether the axis is also a C4 axis); Td from O
  through R -> det(R) R, and Th, Oh, Ih as T, O, I times {E, i} (g/u).
- Linear groups C_inf_v and D_inf_h: the finite subgroups C8v and D8h stand for them (rotations by
  multiples of 45 degrees). Their irreducible representations up to Phi (|Lambda| <= 3) keep the
  infinite group's characters, labelled Sigma+ (A1), Sigma- (A2), Pi (E1), Delta (E2), Phi (E3).

IR activity: the species occurs in the representation of (x, y, z), characters tr R; Raman
activity: it occurs in that of the quadratic forms, characters (tr(R)^2 + tr(R^2)) / 2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core.frozen import Frozen

__all__ = ["CharacterTable", "character_table", "symmetry_number", "LINEAR_ORDER"]

#: Rotation order of the finite subgroups (C8v, D8h) that stand for C_inf_v and D_inf_h.
LINEAR_ORDER = 8
_GOLDEN = (1.0 + np.sqrt(5.0)) / 2.0
_LINEAR_NAMES = {1: "Pi", 2: "Delta", 3: "Phi"}

# Proper-rotation classes, keyed by rotation angle in degrees ("C2z": a C2 about a C4 axis).
_Table = dict[str, dict[int | str, float]]
_T_TABLE: _Table = {"A": {0: 1, 120: 1, 180: 1}, "E": {0: 2, 120: -1, 180: 2}, "T": {0: 3, 120: 0, 180: -1}}
_O_TABLE: _Table = {
    "A1": {0: 1, 120: 1, "C2z": 1, 90: 1, 180: 1},
    "A2": {0: 1, 120: 1, "C2z": 1, 90: -1, 180: -1},
    "E": {0: 2, 120: -1, "C2z": 2, 90: 0, 180: 0},
    "T1": {0: 3, 120: 0, "C2z": -1, 90: 1, 180: -1},
    "T2": {0: 3, 120: 0, "C2z": -1, 90: -1, 180: 1},
}
_I_TABLE: _Table = {
    "A": {0: 1, 72: 1, 144: 1, 120: 1, 180: 1},
    "T1": {0: 3, 72: _GOLDEN, 144: 1 - _GOLDEN, 120: 0, 180: -1},
    "T2": {0: 3, 72: 1 - _GOLDEN, 144: _GOLDEN, 120: 0, 180: -1},
    "G": {0: 4, 72: -1, 144: -1, 120: 1, 180: 0},
    "H": {0: 5, 72: 0, 144: 0, 120: -1, 180: 1},
}


@dataclass(frozen=True, eq=False)
class CharacterTable(Frozen):
    """Characters of a point group's irreducible representations, one column per operation.

    Attributes
    ----------
    group : str
        Schoenflies symbol in ASCII (``"C2v"``, ``"Dinfh"``).
    labels : tuple of str
        Mulliken labels in ASCII (``"A1"``, ``"B2u"``, ``"E2g"``, ``"A1'"``, ``"Sigma_g+"``).
    characters : (n_irreps, n_operations) ndarray
        Real characters; column j belongs to operation j of the group (`PointGroup.operations`).
        A complex-conjugate pair is one real row (its characters summed), as in textbooks.
    dimensions : (n_irreps,) ndarray of int
        Degeneracy of each species (1, 2, 3, 4 or 5).
    ir_active : (n_irreps,) ndarray of bool
        The species transforms like x, y or z (a fundamental of it is IR-allowed).
    raman_active : (n_irreps,) ndarray of bool
        The species transforms like a quadratic form (Raman-allowed).
    """

    group: str
    labels: tuple[str, ...]
    characters: NDArray[np.float64]
    dimensions: NDArray[np.intp]
    ir_active: NDArray[np.bool_]
    raman_active: NDArray[np.bool_]

    def index(self, label: str) -> int:
        """Row of `label`; ValueError naming the known labels when it is not one."""
        if label not in self.labels:
            raise ValueError(f"{label!r} is not a species of {self.group}; its species are {list(self.labels)}")
        return self.labels.index(label)

    def is_ir_active(self, label: str) -> bool:
        """True when species `label` transforms like x, y or z."""
        return bool(self.ir_active[self.index(label)])

    def is_raman_active(self, label: str) -> bool:
        """True when species `label` transforms like a quadratic form."""
        return bool(self.raman_active[self.index(label)])

    def reduce(self, characters: ArrayLike) -> NDArray[np.float64]:
        """(n_irreps,) multiplicities of each species in a representation with these characters.

        n_G = <chi_G, chi> / <chi_G, chi_G>: the reduction formula, written so that a real E
        made of a complex-conjugate pair counts once.
        """
        chi = np.asarray(characters, dtype=float)
        return (self.characters @ chi) / np.sum(self.characters**2, axis=1)

    def table(self) -> str:
        """Plain-text listing: one row per species, with its IR and Raman activity."""
        lines = [f"{self.group}: {len(self.labels)} species over {self.characters.shape[1]} operations",
                 f"{'species':<10} {'dim':>3} {'IR':>4} {'Raman':>6}"]
        for k, label in enumerate(self.labels):
            lines.append(f"{label:<10} {int(self.dimensions[k]):>3} {'yes' if self.ir_active[k] else 'no':>4} "
                         f"{'yes' if self.raman_active[k] else 'no':>6}")
        return "\n".join(lines)


def character_table(group: str, operations: ArrayLike) -> CharacterTable:
    """The character table of point group `group` over its `operations` (standard frame).

    Parameters
    ----------
    group : str
        Schoenflies symbol in ASCII, as `PointGroup.name` gives it.
    operations : (n_operations, 3, 3) array_like
        The group's orthogonal matrices in the standard frame (z principal, x secondary axis).

    Returns
    -------
    CharacterTable

    Raises
    ------
    RuntimeError
        The representations found do not add up to the group (sum of squared dimensions != order).
    """
    ops = np.asarray(operations, dtype=float)
    if group in ("T", "Td", "Th", "O", "Oh", "I", "Ih"):
        labels, rows = _cubic(group, ops)
        complete = True
    else:
        labels, rows, complete = _axial(group, ops)
    characters = np.array(rows, dtype=float).reshape(len(labels), len(ops))
    norms = np.sum(characters**2, axis=1) / len(ops)
    if complete and not np.isclose(np.sum(characters[:, 0] ** 2 / norms), len(ops)):
        raise RuntimeError(f"the species found for {group} do not add up to its {len(ops)} operations")
    traces = np.trace(ops, axis1=1, axis2=2)
    squares = (traces**2 + np.trace(ops @ ops, axis1=1, axis2=2)) / 2.0
    ir = np.abs(characters @ traces) > 1e-6 * len(ops)
    raman = np.abs(characters @ squares) > 1e-6 * len(ops)
    return CharacterTable(group=group, labels=tuple(labels), characters=characters,
                          dimensions=np.rint(characters[:, 0]).astype(np.intp), ir_active=ir, raman_active=raman)


def symmetry_number(name: str) -> int:
    """Rotational symmetry number sigma of point group `name` (Schoenflies, ASCII).

    C1, Ci, Cs: 1; Cn, Cnv, Cnh: n; Dn, Dnd, Dnh: 2n; S2n: n; T, Td, Th: 12; O, Oh: 24;
    I, Ih: 60; Cinfv: 1; Dinfh: 2.
    """
    fixed = {"C1": 1, "Ci": 1, "Cs": 1, "Cinfv": 1, "Dinfh": 2, "T": 12, "Td": 12, "Th": 12,
             "O": 24, "Oh": 24, "I": 60, "Ih": 60}
    if name in fixed:
        return fixed[name]
    digits = "".join(ch for ch in name if ch.isdigit())
    if not digits or name[0] not in "CDS":
        raise ValueError(f"{name!r} is not a point-group symbol such as 'C2v', 'D6h' or 'Td'")
    n = int(digits)
    return {"C": n, "D": 2 * n, "S": n // 2}[name[0]]


# ---------------------------------------------------------------------------------- cubic groups
def _rotation_angle(rotation: NDArray[np.float64]) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0))))


def _rotation_axis(rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    values, vectors = np.linalg.eig(rotation)
    return np.real(vectors[:, int(np.argmin(np.abs(values - 1.0)))])


def _cubic(group: str, ops: NDArray[np.float64]) -> tuple[list[str], list[NDArray[np.float64]]]:
    dets = np.linalg.det(ops)
    proper = ops * dets[:, None, None]          # Td -> O; Th, Oh, Ih: R = i * (-R)
    base: _Table = {"T": _T_TABLE, "Th": _T_TABLE, "O": _O_TABLE, "Td": _O_TABLE, "Oh": _O_TABLE}.get(group, _I_TABLE)
    quarter = [_rotation_axis(r) for r in proper if abs(_rotation_angle(r) - 90.0) < 1.0]
    keys: list[int | str] = []
    for rotation in proper:
        angle = int(round(_rotation_angle(rotation)))
        axis = _rotation_axis(rotation) if angle == 180 else None
        if axis is not None and any(abs(abs(axis @ q) - 1.0) < 1e-6 for q in quarter):
            keys.append("C2z")
        else:
            keys.append(angle)
    labels: list[str] = []
    rows: list[NDArray[np.float64]] = []
    parities = [("g", 1.0), ("u", -1.0)] if group in ("Th", "Oh", "Ih") else [("", 1.0)]
    for suffix, parity in parities:
        for label, row in base.items():
            labels.append(label + suffix)
            rows.append(np.array([row[key] * (parity if det < 0 else 1.0) for key, det in zip(keys, dets)]))
    return labels, rows


# ---------------------------------------------------------------------------------- axial groups
def _find(ops: NDArray[np.float64], matrix: NDArray[np.float64]) -> int | None:
    hits = np.flatnonzero(np.all(np.abs(ops - matrix) < 1e-6, axis=(1, 2)))
    return int(hits[0]) if hits.size else None


def _rotation_z(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _principal_order(ops: NDArray[np.float64]) -> int:
    """Largest n with C_n or S_n about z in the group (1 when there is none)."""
    order = 1
    for n in range(2, 4 * LINEAR_ORDER + 1):
        rotation = _rotation_z(2 * np.pi / n)
        if _find(ops, rotation) is not None or _find(ops, rotation @ np.diag([1.0, 1.0, -1.0])) is not None:
            order = n
    return order


def _basis(points: NDArray[np.float64], m: int, p: int) -> NDArray[np.float64]:
    """(n_points, 2) values of z^p Re (x + i y)^m and z^p Im (x + i y)^m."""
    w = (points[:, 0] + 1j * points[:, 1]) ** m
    return np.stack([w.real, w.imag], axis=1) * points[:, 2:3] ** p


def _representation(ops: NDArray[np.float64], points: NDArray[np.float64], m: int, p: int,
                    columns: list[int]) -> NDArray[np.float64] | None:
    """Characters of the span of the chosen basis functions, or None when it is not closed."""
    values = _basis(points, m, p)[:, columns]
    scale = np.linalg.norm(values)
    if scale < 1e-12:
        return None
    chi = np.empty(len(ops))
    for j, rotation in enumerate(ops):
        moved = _basis(points @ rotation, m, p)[:, columns]
        matrix, *_ = np.linalg.lstsq(values, moved, rcond=None)
        if np.linalg.norm(values @ matrix - moved) > 1e-8 * scale:
            return None
        chi[j] = np.trace(matrix)
    return chi


def _axial(group: str, ops: NDArray[np.float64]) -> tuple[list[str], list[NDArray[np.float64]], bool]:
    linear = group in ("Cinfv", "Dinfh")
    order = _principal_order(ops)
    points = np.random.default_rng(7).uniform(-1.0, 1.0, size=(24, 3))
    h = len(ops)
    one_d: list[NDArray[np.float64]] = []
    two_d: list[tuple[int, NDArray[np.float64]]] = []

    def known(chi: NDArray[np.float64], found: list[NDArray[np.float64]]) -> bool:
        return any(np.allclose(chi, other, atol=1e-6) for other in found)

    for p in (0, 1):
        for m in range(0, order + 1):
            for column in ([0] if m == 0 else [0, 1]):
                chi = _representation(ops, points, m, p, [column])
                if chi is not None and not known(chi, one_d):
                    one_d.append(chi)
    for p in (0, 1):
        for k in range(1, order):
            chi = _representation(ops, points, k, p, [0, 1])
            if chi is None or known(chi, [c for _, c in two_d]):
                continue
            norm = chi @ chi / h
            if np.isclose(norm, 1.0) or (np.isclose(norm, 2.0) and all(abs(chi @ c) < 1e-6 * h for c in one_d)):
                two_d.append((k, chi))
    labels = [_mulliken(group, ops, chi) for chi in one_d] + [_mulliken(group, ops, chi) for _, chi in two_d]
    rows = one_d + [chi for _, chi in two_d]
    if linear:
        ranks = ["Sigma+", "Sigma-", "Pi", "Delta", "Phi"]
        keep = sorted((i for i, label in enumerate(labels) if label),
                      key=lambda i: ("_u" in labels[i], ranks.index(labels[i].replace("_g", "").replace("_u", ""))))
        return [labels[i] for i in keep], [rows[i] for i in keep], False
    ks = {label[2:].rstrip("'gu") for label in labels if label.startswith("E|")}
    labels = [("E" + (label[2:] if len(ks) > 1 else label[2:].lstrip("0123456789"))) if label.startswith("E|")
              else label for label in labels]
    ranked = sorted(range(len(labels)), key=lambda i: (labels[i].endswith(("u", "''")), labels[i][0], labels[i]))
    return [labels[i] for i in ranked], [rows[i] for i in ranked], True


def _character(ops: NDArray[np.float64], chi: NDArray[np.float64], matrix: NDArray[np.float64]) -> float | None:
    j = _find(ops, matrix)
    return None if j is None else float(chi[j])


def _mulliken(group: str, ops: NDArray[np.float64], chi: NDArray[np.float64]) -> str:
    """Mulliken label of the representation with characters `chi`; E_k written as ``E|<k>...`` (the caller drops k when only one k occurs).

    For the linear groups an empty string marks a representation of the finite subgroup that
    is not one of the infinite group's (B-type, or |Lambda| > 3).
    """
    inversion = _character(ops, chi, -np.eye(3))
    sigma_h = _character(ops, chi, np.diag([1.0, 1.0, -1.0]))
    order = _principal_order(ops)
    proper_order = max(n for n in range(1, order + 1) if _find(ops, _rotation_z(2 * np.pi / n)) is not None)
    principal = _rotation_z(2 * np.pi / proper_order)
    n_generator = proper_order
    if inversion is None and order == 2 * proper_order:
        principal = _rotation_z(2 * np.pi / order) @ np.diag([1.0, 1.0, -1.0])   # S2n
        n_generator = order
    generator = float(chi[_find(ops, principal) or 0])
    dimension = int(round(chi[0]))
    parity = ""
    if inversion is not None:
        parity = "g" if inversion > 0 else "u"
    elif sigma_h is not None:
        parity = "'" if sigma_h > 0 else "''"
    if group in ("D2", "D2h"):
        if dimension != 1:
            raise RuntimeError(f"{group} has only 1-D species")
        axes = [_character(ops, chi, np.diag(d)) for d in ([-1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, -1.0, -1.0])]
        minus = [k for k, value in enumerate(axes) if value is not None and value > 0]
        label = "A" if len(minus) == 3 else f"B{minus[0] + 1}"
        return label + parity
    c2x = _character(ops, chi, np.diag([1.0, -1.0, -1.0]))
    sigma_v = _character(ops, chi, np.diag([1.0, -1.0, 1.0]))
    secondary = c2x if c2x is not None else sigma_v
    if group in ("Cinfv", "Dinfh"):
        if dimension == 1:
            if generator < 0:
                return ""
            sign = "+" if (sigma_v is None or sigma_v > 0) else "-"
            return f"Sigma_{parity}{sign}" if parity else f"Sigma{sign}"
        k = int(round(np.degrees(np.arccos(np.clip(generator / 2.0, -1, 1))) * n_generator / 360.0))
        name = _LINEAR_NAMES.get(k, "")
        return f"{name}_{parity}" if name and parity else name
    if dimension == 1:
        letter = "A" if generator > 0 else "B"
        subscript = "" if secondary is None else ("1" if secondary > 0 else "2")
        return letter + subscript + parity
    k = int(round(np.degrees(np.arccos(np.clip(generator / 2.0, -1, 1))) * n_generator / 360.0))
    return f"E|{k}{parity}"
