"""The text table of a scene's modes, as `vibra modes` prints it and the report shows it.

One numbering of modes for the table, the renders and the 3-D view (`mode_names`):

- A molecule's vibrations are numbered as Herzberg does (nu1, nu2, ...: by species in the order
  of the character table, decreasing frequency within a species, a degenerate set once;
  `vibra.molecules.numbering`), the numbering of Shimanouchi's observed fundamentals; ν in
  Unicode, ``nu`` in ASCII-safe output. Without a point group (C1, or none found) by
  decreasing frequency alone, and the table says so. The table lists them nu1 first, with the
  wavenumber in cm^-1 and, where known, the species and the observed fundamental.
- Other systems number their non-rigid modes "mode 1", "mode 2", ... from the lowest, and list
  their frequencies with units: omega in rad/s and f in Hz for SI scenes, omega in units of
  sqrt(stiffness / mass) for dimensionless ones (an elastic network's sqrt(gamma / m)).

Rigid-body modes (translations, rotations) are set apart on one line, as 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np

from vibra.solvers.structured.quadratic import QuadraticModes

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from vibra.modes import Modes
    from vibra.pipeline.plan.analysis import MoleculeSymmetry
    from vibra.pipeline.scene import Scene
    from vibra.units import UnitSystem

__all__ = ["frequency_lines", "mode_names", "omega_unit_text", "species_text", "RIGID_RTOL"]

#: A mode with |omega| <= RIGID_RTOL * max |omega| is a rigid-body (zero) mode.
RIGID_RTOL = 1e-6

_Column = tuple[str, str, Callable[[int], str]]


def omega_unit_text(scene: Scene, units: UnitSystem, *, ascii: bool = False) -> str:
    """omega's unit in a table (`vibra.units.omega_unit_text`; an elastic network's is sqrt(gamma/m))."""
    from vibra.units import omega_unit_text as text

    return text(units, stiffness="gamma" if scene.kind == "network" else "k", ascii=ascii)


_GREEK = (("Sigma", "Σ"), ("Pi", "Π"), ("Delta", "Δ"), ("Phi", "Φ"), ("Gamma", "Γ"))


def species_text(label: str, *, ascii: bool = False) -> str:
    """A Mulliken label for a terminal: ``"Sigma_g+"`` -> ``"Σg+"`` (unchanged with `ascii`).

    >>> species_text("Sigma_u+"), species_text("Pi_u", ascii=True), species_text("T2")
    ('Σu+', 'Pi_u', 'T2')
    """
    if ascii:
        return label
    for name, letter in _GREEK:
        if label.startswith(name):
            return letter + label[len(name):].lstrip("_")
    return label


def _text_table(rows: list[int], columns: list[_Column]) -> list[str]:
    """Lines of a text table: per column (header, format spec such as ``">26"``, cell text of row k)."""
    lines = ["  ".join(f"{header:{spec}}" for header, spec, _ in columns).rstrip()]
    lines += ["  ".join(f"{cell(k):{spec}}" for _, spec, cell in columns).rstrip() for k in rows]
    return lines


def _rigid(modes: Modes | QuadraticModes, symmetry: MoleculeSymmetry | None) -> NDArray[np.bool_]:
    if modes.n_modes < 2:
        return np.zeros(modes.n_modes, dtype=bool)
    rigid = np.asarray(modes.zero_modes(RIGID_RTOL), dtype=bool)
    if symmetry is not None:  # the vibrational analysis matched them to translations and rotations
        rigid = rigid | np.array([not s for s in symmetry.species])
    return rigid


def _is_molecule(scene: Scene, modes: Modes | QuadraticModes) -> bool:
    return bool(scene.kind == "molecule" and modes.units.time_s is not None)


def _numbers(scene: Scene, modes: Modes | QuadraticModes, symmetry: MoleculeSymmetry | None) -> tuple[int, ...]:
    """Per mode its number (0 for a rigid mode): Herzberg's for a molecule, from the lowest otherwise."""
    rigid = _rigid(modes, symmetry)
    if _is_molecule(scene, modes):
        if symmetry is not None and len(symmetry.numbers) == modes.n_modes:
            return tuple(0 if rigid[k] else int(n) for k, n in enumerate(symmetry.numbers))
        from vibra.molecules.numbering import herzberg_numbers

        return herzberg_numbers(("A",), ["" if r else "A" for r in rigid], modes.wavenumbers_cm1())
    numbers, count = [0] * modes.n_modes, 0
    for k in range(modes.n_modes):
        if not rigid[k]:
            count += 1
            numbers[k] = count
    return tuple(numbers)


def mode_names(scene: Scene, modes: Modes | QuadraticModes, symmetry: MoleculeSymmetry | None = None, *, ascii: bool = False,
               species: bool = False) -> dict[int, str]:
    """The name of each non-rigid mode by its index in `modes`: ``"ν2"`` (molecules), ``"mode 1"`` (others).

    A molecule's vibrations take Herzberg's numbers (`MoleculeSymmetry.numbers`; decreasing
    frequency alone without a symmetry); other systems' modes are counted from the lowest
    non-rigid one. Rigid-body modes have no name. With `species` a molecule's name carries
    its species where known: ``"ν2 (A1)"``, ``"ν3 (Σu+)"``.
    """
    nu = "nu" if ascii else "ν"
    molecule = _is_molecule(scene, modes)
    names = {}
    for k, n in enumerate(_numbers(scene, modes, symmetry)):
        if not n:
            continue
        names[k] = f"{nu}{n}" if molecule else f"mode {n}"
        label = symmetry.species[k] if molecule and species and symmetry is not None else ""
        if label:
            names[k] += f" ({species_text(label, ascii=ascii)})"
    return names


def numbering_note(scene: Scene, modes: Modes | QuadraticModes, symmetry: MoleculeSymmetry | None = None, *, ascii: bool = False) -> str:
    """One line saying how `mode_names` numbers this scene's modes."""
    if not _is_molecule(scene, modes):
        return "modes numbered from the lowest non-rigid one (mode 1)"
    if symmetry is None or len(symmetry.numbers) != modes.n_modes:
        return "vibrations numbered by decreasing wavenumber (no point group found)"
    if symmetry.group == "C1":
        return "vibrations numbered by decreasing wavenumber (point group C1: one species)"
    group = symmetry.group if ascii else symmetry.group.replace("inf", "∞")
    order = ("Sigma species first, then Pi (a linear triatomic's bend: nu2)"
             if symmetry.group in ("Cinfv", "Dinfh") else f"by species in the order of the {group} character table")
    if not ascii:
        order = order.replace("Sigma", "Σ").replace("Pi", "Π").replace("nu2", "ν2")
    return (f"vibrations numbered as Herzberg does: {order}, decreasing wavenumber within a species, "
            "a degenerate set once")


def frequency_lines(scene: Scene, modes: Modes | QuadraticModes, symmetry: MoleculeSymmetry | None = None, *,
                    ascii: bool = False) -> tuple[str, ...]:
    """A text table of the modes, named as `mode_names` names them, with spectroscopic units, rigid modes apart.

    Parameters
    ----------
    scene : Scene
    modes : Modes or QuadraticModes
    symmetry : MoleculeSymmetry, optional
        Adds each vibration's species and the observed fundamental, with its source below, and
        Herzberg's numbering.
    ascii : bool
        Write ``nu1``, ``cm^-1`` and ``sqrt`` instead of ``ν1``, ``cm⁻¹`` and ``√`` (a terminal
        that cannot show them).
    """
    if isinstance(modes, QuadraticModes):
        return _quadratic_lines(scene, modes, ascii=ascii)
    units = modes.units
    omega = np.asarray(modes.omega) if units.time_s is None else modes.omega_rad_per_s()
    rigid = _rigid(modes, symmetry)
    numbers = _numbers(scene, modes, symmetry)
    names = mode_names(scene, modes, symmetry, ascii=ascii)
    cm1 = "cm^-1" if ascii else "cm⁻¹"
    molecule = _is_molecule(scene, modes)
    if molecule:  # nu1 first, as Herzberg's and Shimanouchi's tables list them
        first = {}  # one row per vibration: a degenerate set once
        for k in sorted(names, key=lambda k: (numbers[k], k)):
            first.setdefault(numbers[k], k)
        moving = list(first.values())
        values = modes.wavenumbers_cm1()
        columns: list[_Column] = [("vibration", ">9", lambda k: names[k]),
                                  (f"wavenumber ({cm1})", ">18", lambda k: f"{values[k]:.2f}")]
    else:
        moving = sorted(names)
        columns = [("mode", ">5", lambda k: str(numbers[k])),
                   (f"omega ({omega_unit_text(scene, units, ascii=ascii)})", ">22", lambda k: f"{omega[k]:.10g}")]
        if units.time_s is not None:
            hz = modes.frequencies_hz()
            columns.append(("f (Hz)", ">14", lambda k: f"{hz[k]:.6g}"))
    if symmetry is not None:
        group = symmetry.group if ascii else symmetry.group.replace("inf", "∞")
        columns.append((f"species ({group})", "<16", lambda k: species_text(symmetry.species[k], ascii=ascii)))
        if symmetry.source is not None:
            observed = symmetry.experimental

            def seen(k: int) -> str:
                if observed[k] is None:
                    return ""
                name = observed[k].name if ascii else observed[k].name.replace("nu", "ν")
                return f"{name} {observed[k].wavenumber_cm1:.0f}"
            columns.append((f"observed ({cm1})", "<16", seen))
    lines = _text_table(moving, columns)
    n_rigid = int(rigid.sum())
    if n_rigid:
        unit = cm1 if molecule else omega_unit_text(scene, units, ascii=ascii)
        largest = float(np.max(np.abs(values[rigid] if molecule else omega[rigid])))
        what = ("a uniform shift of every residue" if scene.system.builder == "gnm" else
                "translations and rotations" if scene.kind in ("molecule", "network") else "rigid-body motion")
        lines.append(f"rigid-body modes: {n_rigid} ({what}), shown as 0 {unit} (computed |value| <= {largest:.1e})")
    if molecule or len(moving) > 1:  # how the rows are numbered, said once (a single mode needs no word)
        lines.append(numbering_note(scene, modes, symmetry, ascii=ascii))
    if symmetry is not None and symmetry.source is not None:
        lines.append(f"observed: gas-phase fundamentals, {symmetry.source}")
    return tuple(lines)


def _quadratic_lines(scene: Scene, modes: QuadraticModes, *, ascii: bool) -> tuple[str, ...]:
    """The table of a gyroscopic or damped system: natural frequency, Hz, damping ratio, growth."""
    units = modes.units
    natural = np.asarray(modes.natural_frequency)
    natural = natural if units.time_s is None else units.omega_to_rad_per_s(natural)
    columns: list[_Column] = [
        ("mode", ">5", lambda k: str(k + 1)),
        (f"omega_n ({omega_unit_text(scene, units, ascii=ascii)})", ">22", lambda k: f"{natural[k]:.10g}")]
    if units.time_s is not None:
        hz = modes.frequencies_hz()
        columns.append(("f (Hz)", ">14", lambda k: f"{hz[k]:.6g}"))
    columns += [("damping ratio", ">14", lambda k: f"{modes.damping_ratio[k]:.3g}"),
                ("motion", "<10", lambda k: "grows" if modes.unstable[k] else "stable")]
    lines = _text_table(list(range(modes.n_modes)), columns)
    lines.append(f"solved as M q'' + G q' + K q = 0 ({modes.path} method): complex mode shapes, "
                 "omega_n = sqrt(lambda_1 lambda_2) per eigenvalue pair")
    return tuple(lines)
