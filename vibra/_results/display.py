"""The interactive 3-D view of modes, one implementation for the report and for Jupyter.

A view is a small JSON-ready dict (the *view data*) and one script, ``vibra-view.js``, that draws
it with the vendored 3Dmol.js (BSD-3-Clause, https://3dmol.csb.pitt.edu); both scripts ship in
``vibra/pipeline/report/assets/`` (read here as package data, no import of the pipeline). Two
kinds of view data:

- ``"modes"`` (`mode_view_data`): one XYZ "atom" per drawn site with its element, the bonds to
  draw, and per mode the displacement of every site, scaled so that its largest motion is
  `MAX_MOTION` of the shortest drawn bond; the page lets 3Dmol.js make the frames
  (``model.vibrate``). The report's scene pages (`vibra.pipeline.plan.views.mode_view`) and
  `ModesResult.show` (notebooks) both build it here.
- ``"crystal"`` (`vibra.crystals.animation.band_view`): a band structure, drawn as an SVG by the
  script, whose clicked point (q, branch) is animated on a supercell as a sequence of frames.

`viewer_html` writes the one HTML of a view: a root element with an id of its own (two views on
one page or notebook never collide), the controls, the data and the call that starts it. The
report links the scripts from its ``assets/`` folder; a notebook output (`View._repr_html_`)
inlines them, once per output: 3Dmol.js is about 530 kB, ``vibra-view.js`` about 12 kB.
"""

from __future__ import annotations

import html
import itertools
import json
import os
import secrets
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from vibra._core.filesystem import atomic_write_text

# (a `vibra.System` is typed Any here: vibra.system imports this package)

__all__ = ["View", "mode_view_data", "system_view", "viewer_html", "asset_bytes", "ASSET_PARTS", "THREEDMOL",
           "SCRIPT", "MAX_MOTION", "CHAIN_SPACING", "MAX_SITES", "MAX_NOTEBOOK_NUMBERS", "MAX_NOTEBOOK_MODES"]

#: Where the scripts ship, inside the package (package data).
ASSET_PARTS = ("pipeline", "report", "assets")
#: The vendored 3Dmol.js (v2.5.5, minified) and vibra's own script.
THREEDMOL, SCRIPT = "3Dmol-min.js", "vibra-view.js"
#: The largest displacement of a drawn mode, as a fraction of the shortest drawn bond.
MAX_MOTION = 0.35
#: Spacing of a chain's drawn sites, in Å-like view units (3Dmol.js draws in Å).
CHAIN_SPACING = 3.0
#: Sites above which a view shows an evenly strided subset (the report writes no view at all).
MAX_SITES = 5000
#: Most displacement numbers (sites x 3 x modes) a notebook output embeds (~0.5 MB of JSON):
#: beyond it fewer modes are embedded, and the cell says so.
MAX_NOTEBOOK_NUMBERS = 60_000
#: Most modes a notebook output embeds (its menu).
MAX_NOTEBOOK_MODES = 100
#: A site's element when nothing names it (drawn grey).
DEFAULT_ELEMENT = "C"

_COUNTER = itertools.count()


def asset_bytes(name: str) -> bytes:
    """The shipped script `name` (`THREEDMOL` or `SCRIPT`), read from the package data."""
    return resources.files("vibra").joinpath(*ASSET_PARTS, name).read_bytes()


def _round(values: Any, digits: int = 4) -> list[Any]:
    return np.round(np.asarray(values, dtype=float), digits).tolist()


def mode_label(modes: Any, k: int, *, wavenumbers: bool, suffix: str = "") -> str:
    """'mode 6: 1595.0 cm⁻¹' (`wavenumbers`: molecules), '... Hz' (SI time), 'ω = ...' otherwise."""
    if wavenumbers and modes.units.time_s is not None:
        return f"mode {k}: {float(modes.wavenumbers_cm1()[k]):.1f} cm⁻¹{suffix}"
    if modes.units.time_s is not None:
        return f"mode {k}: {float(modes.frequencies_hz()[k]):.4g} Hz{suffix}"
    return f"mode {k}: ω = {float(modes.omega[k]):.4g}{suffix}"


def mode_view_data(system: Any, modes: Any, indices: Sequence[int], *, kind: str,
                   elements: Sequence[str], bonds: Sequence[tuple[int, int]], sites: ArrayLike | None = None,
                   labels: Sequence[str] | None = None, note: str = "") -> dict[str, Any]:
    """The ``"modes"`` view data of the modes `indices` of `system` (module docstring).

    Parameters
    ----------
    system : System
        Positions (in its length unit), `expand` (frozen dofs as zeros), ``dim``.
    modes : ModesResult (`vibra._results`; Any here: the package imports this module)
        With real shapes.
    indices : sequence of int
        The modes drawn.
    kind : {"chain", "molecule", "network"}
        How the sites are drawn (a chain: evenly spaced along x, `CHAIN_SPACING` apart).
    elements : sequence of str
        One element per drawn site (colours).
    bonds : sequence of (int, int)
        Pairs of drawn sites (indices into the drawn sites).
    sites : (n_drawn,) array_like of int, optional
        The sites drawn (all by default).
    labels : sequence of str, optional
        One menu label per drawn mode (default `mode_label`).
    note : str
        A line shown under the view (what was left out).
    """
    shapes = np.asarray(modes.shapes)
    n_sites, dim = system.n_sites, system.dim
    chosen = np.arange(n_sites) if sites is None else np.asarray(sites, dtype=np.intp)
    positions = np.zeros((n_sites, 3))
    positions[:, :dim] = np.asarray(system.positions, dtype=float).reshape(n_sites, dim)
    drawn = positions[chosen]
    if kind == "chain":  # evenly spaced along x, whatever the chain's own length unit
        x = drawn[:, 0]
        span = float(x.max() - x.min()) if len(x) > 1 else 0.0
        drawn = np.zeros((len(chosen), 3))
        drawn[:, 0] = (x - x.min()) / span * CHAIN_SPACING * (len(chosen) - 1) if span > 0 else 0.0
    lengths = [float(np.linalg.norm(drawn[i] - drawn[j])) for i, j in bonds]
    scale_length = min((v for v in lengths if v > 0), default=CHAIN_SPACING if kind == "chain" else 1.5)
    views = []
    for n, k in enumerate(indices):
        full = np.asarray(system.expand(shapes[:, k]), dtype=float).reshape(n_sites, dim)
        vectors = np.zeros((len(chosen), 3))
        vectors[:, :dim] = full[chosen]
        largest = float(np.linalg.norm(vectors, axis=1).max(initial=0.0))
        if largest > 0:
            vectors = vectors * (MAX_MOTION * scale_length / largest)
        label = labels[n] if labels is not None else mode_label(modes, int(k), wavenumbers=kind == "molecule")
        views.append({"label": label, "vectors": _round(vectors)})
    return {"kind": kind, "style": kind, "elements": list(elements), "positions": _round(drawn),
            "bonds": [[int(i), int(j)] for i, j in bonds], "modes": views, "note": note}


# ---------------------------------------------------------------------- a system alone (notebooks)
def _spring_pairs(system: Any) -> list[tuple[int, int]]:
    """The site pairs of the system's two-site terms (springs, bond stretches), each once."""
    coupling = system.coupling.tocsr()
    pairs = set()
    for row in range(coupling.shape[0]):
        columns = coupling.indices[coupling.indptr[row]:coupling.indptr[row + 1]]
        touched = np.unique(columns // system.dim)
        if len(touched) == 2:
            pairs.add((int(touched[0]), int(touched[1])))
    return sorted(pairs)


def _kind_of(system: Any) -> str:
    if system.dim == 1:
        return "chain"
    return "molecule" if system.symbols is not None else "network"


def system_view(system: Any, modes: Any, indices: Sequence[int] | None = None, *,
                max_numbers: int = MAX_NOTEBOOK_NUMBERS) -> View:
    """The `View` of `modes` on `system` (what ``modes.show(system)`` returns).

    The drawing follows the system: 1-D positions are a chain (sites evenly spaced, one element
    per distinct mass); a system with chemical symbols (`System.symbols`, set by the molecule
    builders) a molecule, its bonds the two-site terms (bond stretches), or where it has none (a
    Hessian from an engine) the pairs closer than 1.25 times their covalent radii; any other a network,
    its sites joined where consecutive and no farther apart than 1.2 times the median step (a
    protein's C-alpha trace). Sites beyond `MAX_SITES` are shown as an evenly strided subset; the
    modes embedded are capped so that their displacements hold at most `max_numbers` numbers
    (and `MAX_NOTEBOOK_MODES` modes). What is left out is said under the view.

    Raises
    ------
    TypeError
        `system` has no sites (a `GeneralizedSystem`), or `modes` has complex shapes.
    ValueError
        `modes` has no shapes, is not of this system, or an index is out of range.
    """
    if not hasattr(system, "positions") or not hasattr(system, "expand"):
        raise TypeError(f"system must be a vibra.System with positions (the one the modes belong to), got "
                        f"{type(system).__name__}")
    shapes = getattr(modes, "shapes", None)
    if shapes is None:
        raise ValueError("these modes have no shapes (computed with vectors=False); recompute with vectors=True")
    if np.iscomplexobj(shapes):
        raise TypeError(f"{type(modes).__name__} has complex shapes (orbits); the 3-D view draws real normal modes")
    if np.shape(shapes)[0] != system.n_dof:
        raise ValueError(f"modes have {np.shape(shapes)[0]} dofs; system {system.name!r} has {system.n_dof}: pass "
                         "the system the modes were computed from")
    n_modes = np.shape(shapes)[1]
    if indices is None:
        zero = modes.zero_modes(1e-6) if n_modes > 1 else np.zeros(n_modes, dtype=bool)
        indices = [k for k in range(n_modes) if not zero[k]] or list(range(n_modes))
    indices = [int(k) for k in indices]
    for n, k in enumerate(indices):
        if not 0 <= k < n_modes:
            raise ValueError(f"indices[{n}] is {k}; expected a mode index from 0 to {n_modes - 1}")
    kind = _kind_of(system)
    notes = []
    stride = -(-system.n_sites // MAX_SITES)
    sites = np.arange(0, system.n_sites, stride)
    if stride > 1:
        notes.append(f"every {stride}th site shown ({len(sites)} of {system.n_sites})")
    keep = max(1, min(MAX_NOTEBOOK_MODES, max_numbers // (3 * len(sites))))
    if len(indices) > keep:
        notes.append(f"{keep} of {len(indices)} modes embedded (the cap on this output's size: {max_numbers:,} "
                     f"numbers, {MAX_NOTEBOOK_MODES} modes); pass indices= for others")
        indices = indices[:keep]
    positions = np.asarray(system.positions, dtype=float)
    if kind == "chain":
        masses = np.asarray(system.masses, dtype=float)[sites]
        kinds = sorted(set(masses.tolist()))
        palette = ("C", "O", "N", "S", "P", "Fe", "Cl", "Br")
        elements = [palette[min(kinds.index(m), len(palette) - 1)] for m in masses]
        bonds = [(i, i + 1) for i in range(len(sites) - 1)]
    elif kind == "molecule":
        elements = [system.symbols[i] for i in sites]
        where = {int(s): n for n, s in enumerate(sites)}
        pairs = _spring_pairs(system)
        if not pairs:  # a Hessian without bond terms (an engine's): bonds from covalent radii, as the report
            from vibra._core.elements import bonds_from_distances

            pairs = [(int(i), int(j)) for i, j in bonds_from_distances(positions, list(system.symbols))]
        bonds = [(where[i], where[j]) for i, j in pairs if i in where and j in where]
    else:
        elements = [DEFAULT_ELEMENT] * len(sites)
        steps = np.linalg.norm(np.diff(positions[sites], axis=0), axis=1)
        limit = 1.2 * float(np.median(steps)) if steps.size else 0.0
        bonds = [(i, i + 1) for i in range(len(sites) - 1) if steps[i] <= limit]
    data = mode_view_data(system, modes, indices, kind=kind, elements=elements, bonds=bonds, sites=sites,
                          note="; ".join(notes))
    return View(data, title=f"{len(indices)} modes of {system.name!r}")


# ---------------------------------------------------------------------- HTML
def viewer_html(data: dict[str, Any], *, assets: str | None = None) -> str:
    """The HTML of one view: its root element (an id of its own), controls, data and start call.

    Parameters
    ----------
    data : dict
        View data (``"modes"`` or ``"crystal"``; module docstring).
    assets : str, optional
        The folder holding the scripts, relative to the page (the report: ``"../assets"``).
        None inlines both scripts (a notebook output, works offline and without files).
    """
    e = html.escape
    uid = f"vibra-view-{os.getpid():x}-{next(_COUNTER)}-{secrets.token_hex(3)}"
    crystal = data.get("kind") == "crystal"
    style = e(str(data.get("style", "")), quote=True)
    height = "240px" if data.get("style") == "chain" else "420px"
    box = (f"<div class='view3d {style}' style='position:relative;overflow:hidden;width:100%;max-width:900px;"
           f"height:{height};border:1px solid #d8dee4;border-radius:4px'></div>")
    if crystal:
        controls = ("<div class='bands' style='width:100%;max-width:900px'></div>"
                    "<p class='picked' style='font-size:14px;margin:6px 0'></p>")
        help_text = ("Click a point of the bands to animate that branch's mode on a supercell (drag to rotate, "
                     "scroll to zoom).")
    else:
        options = "".join(f"<option value='{k}'>{e(m['label'])}</option>" for k, m in enumerate(data["modes"]))
        controls = ("<div class='controls' style='display:flex;gap:18px;align-items:center;margin:8px 0;"
                    f"font-size:14px'><label>mode <select class='view-mode'>{options}</select></label>"
                    "<label>amplitude <input class='view-amplitude' type='range' min='0.2' max='3' step='0.1' "
                    "value='1'></label><button class='view-play' type='button'>pause</button></div>")
        help_text = ("Drag to rotate, scroll to zoom; the largest motion is drawn at about a third of the "
                     "shortest bond at amplitude 1.")
    note = f"<p class='note'>{e(data['note'])}.</p>" if data.get("note") else ""
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    if assets is None:
        library = asset_bytes(THREEDMOL).decode("utf-8").replace("</script", "<\\/script")
        # an AMD loader (the classic notebook's require.js) would keep 3Dmol.js from making its global
        scripts = (f"<script>(function (define, exports, module) {{\n{library}\n}}).call(window);</script>"
                   f"<script>{asset_bytes(SCRIPT).decode('utf-8')}</script>")
    else:
        scripts = f"<script src='{assets}/{THREEDMOL}'></script><script src='{assets}/{SCRIPT}'></script>"
    return (f"<div class='viewer vibra-view' id='{uid}'>" + (controls + box if crystal else box + controls)
            + f"{note}<p class='note'>{help_text}</p>"
            f"<script type='application/json' class='view-data'>{payload}</script></div>{scripts}"
            f"<script>vibra3d.start(document.getElementById('{uid}'));</script>")


class View:
    """An interactive 3-D view, as Jupyter shows it (`_repr_html_`: the report's viewer, scripts inlined).

    Returned by ``modes.show(system)`` and ``bands.show(crystal)``; display it as a cell's value,
    or write it as a page of its own with `save`. Each output inlines 3Dmol.js (about 530 kB)
    and the view data, and gets element ids of its own.

    Attributes
    ----------
    data : dict
        The view data (module docstring).
    title : str
        What it shows, in a few words (the repr).
    """

    def __init__(self, data: dict[str, Any], *, title: str) -> None:
        self.data = data
        self.title = title

    def __repr__(self) -> str:
        note = f"; {self.data['note']}" if self.data.get("note") else ""
        return f"View({self.title}{note})"

    def _repr_html_(self) -> str:
        return viewer_html(self.data)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the view as a standalone HTML page (scripts inlined: it opens offline), atomically."""
        target = Path(path)
        if target.suffix.lower() not in (".html", ".htm"):
            raise ValueError(f"path must end in .html, got {str(target)!r}")
        page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(self.title)}</title></head>"
                f"<body style='font-family:sans-serif'>{self._repr_html_()}</body></html>")
        return atomic_write_text(target, page)
