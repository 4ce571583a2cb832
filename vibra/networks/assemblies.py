"""Biological assemblies of structure files: the transforms that build them from the asymmetric unit.

A crystal file holds the asymmetric unit; its biological assembly (the dimer, the capsid) is
described by transforms, each a rotation and a translation applied to some of the chains:

- PDB: ``REMARK 350 BIOMOLECULE: n``, ``APPLY THE FOLLOWING TO CHAINS: A, B`` (continued on
  ``AND CHAINS:`` lines), then ``BIOMT1/2/3 k  r11 r12 r13 t1`` rows (`pdb_assemblies`);
- mmCIF: ``_pdbx_struct_assembly_gen`` (assembly id, operator expression such as ``1``,
  ``(1-60)`` or ``(1,2)(3,4)``, label_asym_id list) and ``_pdbx_struct_oper_list`` (matrix[i][j],
  vector[i]) (`mmcif_assemblies`).

`assembly_copies` applies one assembly to sites already read. The convention is ProDy's
(``parsePDB(path, biomol=True)``): the copies follow one another in the order of the transforms,
each holding the sites of the chains its transform names in the asymmetric unit's order; copy k
(from 1, counted over the assembly's transforms) of chain ``A`` is chain ``A{k}`` (``A1``,
``A2``: ProDy keeps the chain id and gives the copy segment name ``k``, or label chain + ``k`` in
mmCIF). Pure: arrays and parsed records in, new arrays out.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vibra._core.validate import ArgumentError

__all__ = ["Transform", "ROTATION_ATOL", "pdb_assemblies", "mmcif_assemblies", "operator_ids", "assembly_transforms",
           "mmcif_residue_chains", "assembly_copies"]

ROTATION_ATOL = 1e-4  #: largest |det R - 1| and |R^T R - I| entry accepted for a transform's rotation


@dataclass(frozen=True, eq=False)
class Transform:
    """One transform of an assembly: x' = rotation @ x + translation, applied to `chains`.

    Attributes
    ----------
    chains : tuple of str
        The chains it applies to (PDB chain ids; mmCIF label_asym_id).
    rotation : (3, 3) ndarray
        The rotation, dimensionless.
    translation : (3,) ndarray
        The translation, in Å.
    name : str
        Where it comes from, for messages (``"BIOMT 2 of BIOMOLECULE 1"``, ``"operator (1)(61)"``).
    """

    chains: tuple[str, ...]
    rotation: NDArray[np.float64]
    translation: NDArray[np.float64]
    name: str


def _number(text: str, file: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not np.isfinite(value):
        raise ValueError(f"{file}: {where} is {text!r}; expected a number")
    return value


def pdb_assemblies(text: str, file: str) -> dict[str, list[Transform]]:
    """The assemblies of a PDB file's ``REMARK 350`` records: id -> transforms, in file order.

    Raises
    ------
    ValueError
        A BIOMT row before any BIOMOLECULE or chain list, a transform missing one of its three
        rows, or a number that does not read (the message names the file and the line).
    """
    assemblies: dict[str, list[Transform]] = {}
    current: str | None = None
    chains: list[str] = []
    rows: dict[str, list[list[float]]] = {}
    order: list[str] = []

    def close() -> None:
        for serial in order:
            matrix = rows[serial]
            if any(row is None for row in matrix):
                missing = [f"BIOMT{i + 1}" for i, row in enumerate(matrix) if row is None]
                raise ValueError(f"{file}: REMARK 350 BIOMOLECULE {current}: transform {serial} lacks "
                                 f"{', '.join(missing)}; expected the three rows BIOMT1, BIOMT2, BIOMT3")
            values = np.array(matrix, dtype=float)
            assemblies[str(current)].append(Transform(tuple(chains), values[:, :3], values[:, 3],
                                                 f"BIOMT {serial} of BIOMOLECULE {current}"))
        rows.clear()
        order.clear()

    for number, line in enumerate(text.splitlines(), start=1):
        if not line.startswith("REMARK 350"):
            continue
        body = line[10:].strip()
        if body.startswith("BIOMOLECULE:"):
            close()
            current = body.split(":", 1)[1].strip()
            assemblies.setdefault(current, [])
            chains = []
        elif body.startswith(("APPLY THE FOLLOWING TO CHAINS:", "AND CHAINS:")):
            close()
            if body.startswith("APPLY"):
                chains = []
            chains.extend(c.strip() for c in body.split(":", 1)[1].split(",") if c.strip())
        elif body.startswith("BIOMT"):
            parts = body.split()
            if current is None or not chains:
                raise ValueError(f"{file}: line {number}: a BIOMT row before its BIOMOLECULE and APPLY THE "
                                 "FOLLOWING TO CHAINS records")
            if parts[0] not in ("BIOMT1", "BIOMT2", "BIOMT3") or len(parts) < 6:
                raise ValueError(f"{file}: line {number}: {body!r}; expected 'BIOMTi  k  r_i1 r_i2 r_i3  t_i'")
            serial = parts[1]
            if serial not in rows:
                rows[serial] = [None, None, None]  # type: ignore[list-item]
                order.append(serial)
            rows[serial][int(parts[0][-1]) - 1] = [_number(p, file, f"line {number}") for p in parts[2:6]]
    close()
    return {key: value for key, value in assemblies.items() if value}


def _column(table: Mapping[str, str | list[str]], key: str) -> list[str]:
    value = table.get(key)
    return [] if value is None else (value if isinstance(value, list) else [value])


def operator_ids(expression: str, file: str = "", known: Sequence[str] | None = None) -> list[tuple[str, ...]]:
    """The operator products of an mmCIF ``oper_expression``, in order: ``"1"`` -> [("1",)],
    ``"(1-3)"`` -> [("1",), ("2",), ("3",)], ``"(1,2)(3,4)"`` -> [("1", "3"), ("1", "4"),
    ("2", "3"), ("2", "4")] (the rightmost operator is applied first).

    Raises
    ------
    ValueError
        An expression that does not read, or one naming an operator not in `known` (when given).
    """
    text = expression.replace(" ", "")
    groups = re.findall(r"\(([^()]*)\)", text) if text.startswith("(") else [text]
    if not text or (text.startswith("(") and "".join(f"({g})" for g in groups) != text):
        raise ValueError(f"{file}: oper_expression {expression!r} does not read; expected operator ids such as "
                         "'1', '(1-60)', '1,2' or '(1,2)(3,4)'")
    lists: list[list[str]] = []
    for group in groups:
        ids: list[str] = []
        for item in group.split(","):
            ends = item.split("-")
            if len(ends) == 2 and ends[0].isdigit() and ends[1].isdigit() and int(ends[0]) <= int(ends[1]):
                ids.extend(str(i) for i in range(int(ends[0]), int(ends[1]) + 1))
            elif item and "-" not in item:
                ids.append(item)
            else:
                raise ValueError(f"{file}: oper_expression {expression!r}: {item!r} is not an operator id or a "
                                 "range first-last")
        if known is not None:
            for name in ids:
                if name not in known:
                    raise ValueError(f"{file}: oper_expression {expression!r} names operator {name!r}, which "
                                     f"_pdbx_struct_oper_list does not hold (its ids: {_listed(list(known))})")
        lists.append(ids)
    products: list[tuple[str, ...]] = [()]
    for ids in lists:
        products = [done + (name,) for done in products for name in ids]
    return products


def mmcif_assemblies(table: Mapping[str, str | list[str]], file: str) -> dict[str, list[Transform]]:
    """The assemblies of an mmCIF dictionary (Biopython's ``MMCIF2Dict``): id -> transforms, in the
    order of the ``_pdbx_struct_assembly_gen`` rows and of each row's operator expression.

    Raises
    ------
    ValueError
        An operator expression that does not read or names an operator not in
        ``_pdbx_struct_oper_list``, a matrix entry that is not a number (naming the file).
    """
    gen = "_pdbx_struct_assembly_gen."
    ids = _column(table, gen + "assembly_id")
    expressions = _column(table, gen + "oper_expression")
    asyms = _column(table, gen + "asym_id_list")
    oper = "_pdbx_struct_oper_list."
    names = _column(table, oper + "id")
    operators: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    for row, name in enumerate(names):
        values = np.empty((3, 4))
        for i in range(3):
            for j in range(4):
                key = oper + (f"matrix[{i + 1}][{j + 1}]" if j < 3 else f"vector[{i + 1}]")
                column = _column(table, key)
                text = column[row] if row < len(column) else "?"
                values[i, j] = _number(text, file, f"_pdbx_struct_oper_list {key.split('.')[1]} of operator {name!r}")
        operators[name] = (values[:, :3], values[:, 3])
    assemblies: dict[str, list[Transform]] = {}
    for assembly, expression, asym in zip(ids, expressions, asyms):
        chains = tuple(c.strip() for c in asym.replace(";", "").split(",") if c.strip())
        for product in operator_ids(expression, file, known=list(operators)):
            rotation, translation = np.eye(3), np.zeros(3)
            for name in reversed(product):  # the rightmost applies first: x -> R_l (R_r x + t_r) + t_l
                r, t = operators[name]
                rotation, translation = r @ rotation, r @ translation + t
            assemblies.setdefault(assembly, []).append(
                Transform(chains, rotation, translation, f"operator {''.join(f'({n})' for n in product)} of "
                                                         f"assembly {assembly}"))
    return assemblies


def mmcif_residue_chains(table: Mapping[str, str | list[str]]) -> dict[str, str]:
    """Residue label (``"chain:RESNAMEnumber[icode]"``, the chain and number as Biopython reads them:
    auth_asym_id and auth_seq_id where given) -> label_asym_id, the chain an mmCIF assembly names."""
    site = "_atom_site."
    asym = _column(table, site + "label_asym_id")
    chain = _column(table, site + "auth_asym_id") or asym
    number = _column(table, site + "auth_seq_id") or _column(table, site + "label_seq_id")
    name = _column(table, site + "label_comp_id")
    code = _column(table, site + "pdbx_PDB_ins_code") or ["?"] * len(asym)
    return {f"{c}:{n}{s}{'' if i in ('?', '.') else i}": a
            for a, c, s, n, i in zip(asym, chain, number, name, code)}


def _listed(names: list[str], limit: int = 12) -> str:
    shown = ", ".join(names[:limit]) or "none"
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def assembly_transforms(assemblies: Mapping[str, list[Transform]], assembly: int | str, file: str
                        ) -> list[Transform]:
    """The transforms of assembly `assembly`, each checked to be a rotation plus a translation.

    Raises
    ------
    ArgumentError
        (argument ``"assembly"``) A file without assembly records, or an id it does not have (the
        ids it has listed).
    ValueError
        A transform whose matrix is not orthogonal or whose determinant is not 1 (within
        `ROTATION_ATOL`): the message names the transform and which.
    """
    if not assemblies:
        raise ArgumentError("assembly", f"{file}: assembly is {assembly!r}, but the file has no biological-assembly "
                            "records (PDB REMARK 350 BIOMT rows, mmCIF _pdbx_struct_assembly_gen); leave assembly "
                            "out to read the asymmetric unit")
    key = str(assembly)
    if key not in assemblies:
        raise ArgumentError("assembly", f"{file}: assembly is {assembly!r}; the file has "
                            f"{'assembly' if len(assemblies) == 1 else 'assemblies'} {_listed(list(assemblies))}")
    transforms = assemblies[key]
    for transform in transforms:
        r = transform.rotation
        gap = float(np.max(np.abs(r.T @ r - np.eye(3))))
        det = float(np.linalg.det(r))
        problems = []
        if gap > ROTATION_ATOL:
            problems.append(f"not orthogonal (largest |R^T R - I| entry {gap:.3g})")
        if abs(det - 1.0) > ROTATION_ATOL:
            problems.append(f"its determinant is {det:.6g}, not 1" + (" (a reflection)" if det < 0 else ""))
        if problems:
            raise ValueError(f"{file}: the matrix of {transform.name} is not a rotation: {' and '.join(problems)} "
                             f"(tolerance {ROTATION_ATOL:g}); expected a rotation matrix")
    return transforms


def assembly_copies(positions: NDArray[np.float64], chains: Sequence[str], transforms: Sequence[Transform]
                    ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """The sites of an assembly: (site of the asymmetric unit, copy number from 1, position in Å)
    for each, copies in transform order, each copy in the asymmetric unit's order.

    Parameters
    ----------
    positions : (n_sites, 3) ndarray
        The asymmetric unit's sites, in Å.
    chains : sequence of str
        Each site's chain as the transforms name it (PDB chain id; mmCIF label_asym_id).
    transforms : sequence of Transform
        The assembly's transforms (`assembly_transforms`).
    """
    positions = np.asarray(positions, dtype=float)
    chain_array = np.asarray(list(chains), dtype=object)
    sources, copies, moved = [], [], []
    for number, transform in enumerate(transforms, start=1):
        index = np.flatnonzero(np.isin(chain_array, list(transform.chains)))
        if index.size == 0:
            continue
        sources.append(index)
        copies.append(np.full(index.size, number, dtype=np.intp))
        moved.append(positions[index] @ transform.rotation.T + transform.translation)
    if not sources:
        return np.empty(0, dtype=np.intp), np.empty(0, dtype=np.intp), np.empty((0, 3))
    return np.concatenate(sources), np.concatenate(copies), np.concatenate(moved)
