"""Off-screen pyvista renders of mode shapes: the only module of vibra that imports pyvista.

The renderer draws what the plan computed and nothing more:

- A molecule: atoms as spheres (sized and coloured by element, from `ase.data`), bonds as
  tubes, one arrow per atom along its displacement in the mode; degenerate modes side by
  side in one image. The elements and bonds come in a `MoleculeStructure`, and the per-mode
  symmetry / IR-activity text in `hints`, both computed by `vibra.pipeline.plan`.
- A chain: a row of masses (sphere volume proportional to mass) per mode, one row per mode,
  with displacement arrows (along the chain for axial motion, across it for a string).
  Long chains show an evenly decimated set of sites, and the caption says so.

Every image is written atomically by `vibra._core.filesystem.atomic_write` (a temporary file in the
destination folder, then renamed), so an interrupted run never leaves a half-written PNG.
One `SceneRenderer` reuses its plotters for all images of a scene.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core.filesystem import atomic_write
from vibra.pipeline.render_geometry import (MAX_CHAIN_SITES, MAX_NETWORK_ARROWS, arrow_start, chain_sites,
                                            displacements3, molecule_bonds, molecule_symbols, network_arrow_step,
                                            positions3, view_direction)

if TYPE_CHECKING:
    from vibra.crystals.supercell import SupercellMode
    from vibra.modes import Modes
    from vibra.pipeline.scene import Scene
    from vibra.system import System

__all__ = ["SceneRenderer", "MoleculeStructure", "write_png", "write_gif", "molecule_symbols", "molecule_bonds",
           "chain_sites", "MAX_CHAIN_SITES", "MAX_NETWORK_ARROWS", "network_arrow_step", "view_direction"]

_GIF_FRAMES = 16


@dataclass(frozen=True)
class MoleculeStructure:
    """What the renderer draws of a molecule besides its positions: elements and bonds.

    Attributes
    ----------
    symbols : tuple of str
        Chemical symbol of each site (sets the sphere's size and colour).
    bonds : tuple of (int, int)
        Site pairs joined by a bond tube.
    """

    symbols: tuple[str, ...]
    bonds: tuple[tuple[int, int], ...]


def _report_theme() -> Any:
    """A fresh document theme for reports (never edits `pv.global_theme`)."""
    import pyvista as pv

    theme = pv.themes.DocumentTheme()
    theme.background = "white"
    theme.font.color = "black"
    theme.font.size = 14
    theme.font.label_size = 14
    theme.font.title_size = 14
    theme.show_edges = False
    return theme


def write_png(image: NDArray[np.uint8], path: str | os.PathLike[str]) -> Path:
    """Write an (height, width, 3 or 4) uint8 image to `path` as PNG, atomically (`vibra._core.filesystem`)."""
    from PIL import Image

    picture = Image.fromarray(np.ascontiguousarray(image))
    return atomic_write(path, lambda temporary: picture.save(temporary, format="PNG"))


def write_gif(frames: Sequence[NDArray[np.uint8]], path: str | os.PathLike[str], *,
              frame_ms: int = 80) -> Path:
    """Write frames as a looping animated GIF at `path`, atomically (frame_ms per frame)."""
    from PIL import Image

    images = [Image.fromarray(np.ascontiguousarray(f)).convert("RGB").quantize(
        colors=128, method=Image.Quantize.FASTOCTREE) for f in frames]
    return atomic_write(path, lambda temporary: images[0].save(
        temporary, format="GIF", save_all=True, append_images=images[1:], duration=frame_ms, loop=0))


# ---------------------------------------------------------------------- labels and arrows
def _default_structure(scene: Scene, system: System) -> MoleculeStructure:
    """Elements and bonds for a caller that passed none (`vibra.pipeline.plan` always passes them)."""
    params = scene.system.parameters
    symbols = molecule_symbols(system, params.get("symbols"))
    return MoleculeStructure(tuple(symbols), tuple(molecule_bonds(system, symbols, params.get("springs"))))


def _frequency_text(scene: Scene, modes: Modes, k: int) -> str:
    """Mode k's frequency with its unit, in Unicode (cm⁻¹ for a molecule, ω in rad/s or √(k/m) otherwise)."""
    from vibra.units import omega_unit_text

    units = modes.units
    if scene.kind == "molecule" and units.time_s is not None:
        return f"{float(modes.wavenumbers_cm1()[k]):.1f} cm⁻¹"
    value = float(modes.omega[k]) if units.time_s is None else float(modes.omega_rad_per_s()[k])
    return f"ω = {value:.4g} {omega_unit_text(units, stiffness='gamma' if scene.kind == 'network' else 'k')}"


def _mode_name(names: Mapping[int, str] | None, k: int) -> str:
    """Mode k's name as the plan numbers it (`vibra.pipeline.plan.tables.mode_names`: "ν2 (B2)",
    "mode 1"); its index in Modes ("mode 6") for a caller that passed none."""
    return (names or {}).get(int(k)) or f"mode {k}"


def _symmetry_line(line: str) -> str:
    """A hint line with its species set as mathtext and ∞ in the group (``Sigma_u+ (Dinfh)`` -> Σu⁺ (D∞h))."""
    from vibra.charts.spectra import species_text

    line = line.replace("Dinfh", "D∞h").replace("Cinfv", "C∞v")
    head, sep, tail = line.partition(" (")
    if sep and " " not in head and tail[:1].isupper():
        return species_text(head) + sep + tail
    return line


def _count_text(n: int) -> str:
    """A count as people read it: 1000000 -> "10⁶", 25000 -> "25,000".

    >>> _count_text(1_000_000), _count_text(25_000), _count_text(41)
    ('10⁶', '25,000', '41')
    """
    exponent = len(str(n)) - 1
    if n >= 10**5 and n == 10**exponent:
        return "10" + str(exponent).translate(str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹"))
    return f"{n:,}"


def _arrow(pv: Any, start: Any, vector: Any, thickness: float) -> Any:
    """An arrow from `start` along `vector` whose shaft (radius `thickness`) and head keep their size
    whatever its length: a short arrow is still a visible head, a long one a longer shaft."""
    length = float(np.linalg.norm(vector))
    tip = min(0.75, 5.0 * thickness / length)
    return pv.Arrow(start=start, direction=vector, scale=length, tip_length=tip,
                    tip_radius=min(2.6 * thickness / length, 4.0), shaft_radius=min(thickness / length, 0.2))


# ---------------------------------------------------------------------- renderer
class SceneRenderer:
    """Renders the images of one scene, reusing one off-screen plotter per layout.

    Parameters
    ----------
    window_size : (int, int)
        Image size in pixels (width, height).
    """

    def __init__(self, window_size: Sequence[int]) -> None:
        import pyvista as pv

        pv.vtk_verbosity("off")  # silences the one "bad X server connection" warning
        self._pv = pv
        self.window_size = (int(window_size[0]), int(window_size[1]))
        self._plotters: dict[tuple[int, int], Any] = {}

    def _plotter(self, shape: tuple[int, int]) -> Any:
        plotter = self._plotters.get(shape)
        if plotter is None:
            plotter = self._pv.Plotter(off_screen=True, window_size=list(self.window_size),
                                       shape=shape, theme=_report_theme(), border=False)
            self._plotters[shape] = plotter
        else:
            for renderer in plotter.renderers:  # keep the lights: plotter.clear() removes them
                renderer.clear_actors()
        # Every add_mesh / camera change of a shown plotter re-renders (slow in software GL):
        # draw everything first, render once in `_snapshot`.
        # (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
        plotter.suppress_rendering = True
        return plotter

    def close(self) -> None:
        """Release every plotter (and its render window)."""
        for plotter in self._plotters.values():
            plotter.close()
        self._plotters.clear()

    def _snapshot(self, plotter: Any) -> NDArray[np.uint8]:
        plotter.suppress_rendering = False
        try:
            for renderer in plotter.renderers:
                renderer.ResetCameraClippingRange()
            plotter.render()  # screenshot() renders only a plotter's first image
            image = plotter.screenshot(None, return_img=True)
        finally:
            plotter.suppress_rendering = True
        return np.asarray(image, dtype=np.uint8)

    # ------------------------------------------------------------------ public
    def render_modes(self, scene: Scene, system: System, modes: Modes, indices: Sequence[int],
                     out_dir: Path, *, structure: MoleculeStructure | None = None,
                     hints: Mapping[int, str] | None = None,
                     names: Mapping[int, str] | None = None,
                     sites: ArrayLike | None = None) -> list[tuple[str, str]]:
        """Render the modes `indices`; returns (file name, caption) per image written.

        `structure` gives a molecule's elements and bonds (`vibra.pipeline.plan` passes the ones it
        computed; when None they are taken from `molecule_symbols` and `molecule_bonds`).
        `hints` maps a mode index to its symmetry / IR-activity text, drawn under the
        frequency and added to the caption. `names` maps a mode index to its name in the
        report's numbering ("ν2 (B2)", "mode 1"; `vibra.pipeline.plan.tables.mode_names`),
        used in titles and captions; without it a mode is called by its index ("mode 6").
        `sites` are the (n_sites, 3) coordinates, in Å, of a Gaussian network model, whose
        System holds one scalar dof per site and no geometry: its modes are drawn as the
        structure coloured by each residue's amplitude.
        """
        if modes.shapes is None:
            raise ValueError("render_modes needs mode shapes; the modes were computed with vectors=False")
        if scene.kind == "network" and sites is not None:
            return [self._scalar_network_image(scene, np.asarray(sites, dtype=float), modes, indices, out_dir, names)]
        if scene.kind == "network":
            return [self._network_image(scene, system, modes, indices, out_dir, names)]
        if scene.kind == "molecule":
            return self._molecule_images(scene, system, modes, indices, out_dir,
                                         structure or _default_structure(scene, system), hints or {}, names)
        return [self._chain_image(scene, system, modes, indices, out_dir, names)]

    def render_gif(self, scene: Scene, system: System, modes: Modes, index: int, out_dir: Path,
                   work_dir: Path, *, structure: MoleculeStructure | None = None,
                   names: Mapping[int, str] | None = None) -> tuple[str, str]:
        """Animated GIF of mode `index` over one period; returns (file name, caption); `names` as
        for `render_modes`."""
        from vibra.charts.renders import annotate_render

        molecule = None
        if scene.kind == "molecule":
            molecule = structure or _default_structure(scene, system)
        frames = []
        for phase in np.linspace(0.0, 2.0 * np.pi, _GIF_FRAMES, endpoint=False):
            plotter = self._plotter((1, 1))
            if molecule is not None:
                view = view_direction(positions3(system), [displacements3(system, np.asarray(modes.shapes)[:, index])])
                title, points = self._draw_molecule(plotter, scene, system, modes, index, molecule, view, phase=phase,
                                                    arrows=False, names=names)
                self._frame(plotter, positions3(system).mean(axis=0), points, view)
            else:
                title = self._draw_chain(plotter, scene, system, modes, index, phase=phase, names=names)
            frames.append(annotate_render(self._snapshot(plotter), titles=[title]))
        name = f"{scene.name}_mode{index}.gif"
        write_gif(frames, out_dir / name)
        return name, (f"{scene.title}: animation of {_mode_name(names, index)} ({_frequency_text(scene, modes, index)}), "
                      "displacements exaggerated")

    # ------------------------------------------------------------------ crystals
    def render_supercell_mode(self, scene: Scene, mode: SupercellMode, out_dir: Path, *, frames: int,
                              frequency: str) -> tuple[str, str]:
        """Animated GIF of a crystal's mode on a supercell (a `vibra.crystals.SupercellMode`), one period.

        Atoms are spheres (coloured by element where the label is one), the supercell is drawn
        as its edges; the displacements are scaled so that the largest is 0.25 of the shortest
        distance between two atoms. Returns (file name, caption).
        """
        pv = self._pv
        from ase.data import atomic_numbers
        from ase.data.colors import jmol_colors

        rest = np.asarray(mode.positions)
        sample = rest[: min(len(rest), 400)]
        gaps = np.linalg.norm(sample[:, None, :] - sample[None, :, :], axis=-1)
        gaps[gaps <= 1e-9] = np.inf
        nearest = float(gaps.min()) if np.isfinite(gaps).any() else 1.0
        radius = 0.22 * nearest
        kinds = sorted(set(mode.symbols))
        named = ("steelblue", "darkorange", "seagreen", "crimson", "mediumpurple", "goldenrod")
        palette = {k: (tuple(jmol_colors[atomic_numbers[k]]) if atomic_numbers.get(k, 0) > 0 else named[i % len(named)])
                   for i, k in enumerate(kinds)}
        corners = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], dtype=float) @ mode.cell
        edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]
        sphere = pv.Sphere(radius=radius, theta_resolution=16, phi_resolution=16)
        images = []
        camera = None
        for phase in np.linspace(0.0, 2.0 * np.pi, frames, endpoint=False):
            plotter = self._plotter((1, 1))
            shown = rest + 0.25 * nearest * mode.displacements(phase)
            for kind in kinds:
                chosen = np.array([s == kind for s in mode.symbols])
                glyphs = pv.PolyData(shown[chosen]).glyph(geom=sphere, scale=False, orient=False)
                plotter.add_mesh(glyphs, color=palette[kind], smooth_shading=True, specular=0.3)
            for i, j in edges:
                plotter.add_mesh(pv.Line(corners[i], corners[j]), color="gray", line_width=2)
            plotter.add_text(f"{scene.title}\n{frequency}", position="upper_left", font_size=12, color="black")
            if camera is None:
                plotter.camera_position = "iso"
                plotter.camera.elevation = -10
                plotter.reset_camera()
                plotter.camera.zoom(1.2)  # the whole supercell in the frame (a cube, for cubic lattices)
                camera = plotter.camera_position
            else:
                plotter.camera_position = camera
            images.append(self._snapshot(plotter))
        name = f"{scene.name}_mode.gif"
        write_gif(images, out_dir / name)
        return name, (f"{scene.title}: {frequency} on a supercell of {len(rest)} atoms, one period in "
                      f"{frames} frames (displacements exaggerated: largest 0.25 of the nearest distance)")

    # ------------------------------------------------------------------ molecules
    def _molecule_images(self, scene: Scene, system: System, modes: Modes, indices: Sequence[int],
                         out_dir: Path, structure: MoleculeStructure,
                         hints: Mapping[int, str], names: Mapping[int, str] | None) -> list[tuple[str, str]]:
        from vibra.charts.renders import annotate_render

        groups: list[list[int]] = []
        # degenerate sets among the drawn modes; a mode's omega_error can be loose (a rigid mode's bound
        # may span the lowest vibrations), so members must also agree to 1e-6 of the largest omega
        omega = np.asarray(modes.omega)
        scale = 1e-6 * float(np.abs(omega).max(initial=0.0))
        drawn = {int(k) for k in indices}
        degenerate = {int(i): [int(j) for j in g if int(j) in drawn and abs(omega[j] - omega[i]) <= scale]
                      for g in modes.degenerate_groups(1e-6) for i in g if int(i) in drawn}
        for k in indices:
            group = degenerate.get(int(k), [int(k)])
            if any(int(k) in g for g in groups):
                continue
            groups.append(group)
        positions = positions3(system)
        shapes = np.asarray(modes.shapes)
        images = []
        for group in groups:
            # one view for the molecule's degenerate partners: no atom hidden, their motions shown longest
            view = view_direction(positions, [displacements3(system, shapes[:, k]) for k in group])
            plotter = self._plotter((1, len(group)))
            titles, reach = [], []
            for column, k in enumerate(group):
                plotter.subplot(0, column)
                title, points = self._draw_molecule(plotter, scene, system, modes, k, structure, view, hint=hints.get(k),
                                                    names=names)
                titles.append(title)
                reach.append(points)
            for column in range(len(group)):  # one scale for the partners: the same molecule, the same size
                plotter.subplot(0, column)
                self._frame(plotter, positions.mean(axis=0), np.vstack(reach), view)
            name = f"{scene.name}_mode{group[0]}.png"
            image = annotate_render(self._snapshot(plotter), grid=(1, len(group)), titles=titles,
                                    font_size=12.0 if len(group) < 3 else 10.5)
            write_png(image, out_dir / name)
            label = " and ".join(dict.fromkeys(_mode_name(names, k) for k in group))  # a degenerate set: one name
            together = f" (degenerate, x{len(group)}, side by side)" if len(group) > 1 else ""
            hint = hints.get(group[0])
            text = _frequency_text(scene, modes, group[0]) + (f", {hint}" if hint else "")
            what = "vibration " if names else ""  # "Vibration ν2": a page capitalises a caption's first letter
            images.append((name, f"{scene.title}: {what}{label}{together}: {text}; viewed from the direction that "
                           "hides no atom"))
        return images

    def _draw_molecule(self, plotter: Any, scene: Scene, system: System, modes: Modes, k: int,
                       structure: MoleculeStructure, view: tuple[Any, Any], *, phase: float | None = None,
                       arrows: bool = True, hint: str | None = None,
                       names: Mapping[int, str] | None = None) -> tuple[str, NDArray[np.float64]]:
        """Draw mode k in the current subplot; returns its title and the points the camera must frame."""
        pv = self._pv
        from ase.data import atomic_numbers, covalent_radii
        from ase.data.colors import jmol_colors

        positions = positions3(system)
        numbers = [atomic_numbers[symbol] for symbol in structure.symbols]
        displacement = displacements3(system, np.asarray(modes.shapes)[:, k])
        bond_list = list(structure.bonds)
        lengths = [np.linalg.norm(positions[i] - positions[j]) for i, j in bond_list]
        reference = min(lengths) if lengths else 1.0
        size = max(float(np.linalg.norm(displacement, axis=1).max()), 1e-300)
        displacement = displacement * (0.8 * reference / size)  # longest arrow: 0.8 bond lengths
        shown = positions if phase is None else positions + 0.35 * np.cos(phase) * displacement
        radii = 0.35 * covalent_radii[numbers] + 0.1
        for i, z in enumerate(numbers):
            plotter.add_mesh(pv.Sphere(radius=float(radii[i]), center=shown[i], theta_resolution=24,
                                       phi_resolution=24), color=tuple(jmol_colors[z]), smooth_shading=True,
                             specular=0.3)
        for i, j in bond_list:
            line = pv.Line(shown[i], shown[j])
            plotter.add_mesh(line.tube(radius=0.1 * reference), color="lightgray", smooth_shading=True,
                             opacity=0.5)  # see-through: arrows along a bond stay visible
        reach = [positions + radii.max(), positions - radii.max()]
        if arrows:
            for i in range(len(positions)):
                vector = displacement[i]
                if float(np.linalg.norm(vector)) < 0.02 * 0.8 * reference:  # under 2% of the largest motion
                    continue
                start = arrow_start(positions, bond_list, i, vector, float(radii[i]))
                plotter.add_mesh(_arrow(pv, start, vector, 0.035 * reference), color="crimson", smooth_shading=True)
                reach.append(np.vstack([start, start + vector]))
        head = f"{_mode_name(names, k)} {_frequency_text(scene, modes, k)}" if names else \
            f"mode {k}: {_frequency_text(scene, modes, k)}"
        lines = [head] + ([] if not hint else hint.split("; "))
        return "\n".join(_symmetry_line(line) for line in lines), np.vstack(reach)

    def _frame(self, plotter: Any, centre: Any, points: Any, view: tuple[Any, Any]) -> None:
        """Point the camera of the current subplot along `view` and zoom until `points` fill the panel,
        below its title lines."""
        direction, up = (np.asarray(v, dtype=float) for v in view)
        right = np.cross(up, direction)
        flat = np.asarray(points) - centre
        across, upward = flat @ right, flat @ up
        middle = centre + right * 0.5 * (across.max() + across.min()) + up * 0.5 * (upward.max() + upward.min())
        half_width = 0.5 * float(np.ptp(across)) + 1e-9
        half_height = 0.5 * float(np.ptp(upward)) + 1e-9
        rows, columns = plotter.shape
        aspect = (self.window_size[0] / columns) / (self.window_size[1] / rows)
        camera = plotter.camera
        camera.parallel_projection = True  # framed exactly: the extent on screen is the extent in space
        scale = max(1.12 * half_width / aspect, 1.12 * half_height) / 0.86  # the top 14% holds the title
        camera.focal_point = tuple(middle + up * 0.14 * scale)
        camera.position = tuple(middle + up * 0.14 * scale + direction * 50.0 * (half_width + half_height))
        camera.up = tuple(up)
        camera.parallel_scale = scale
        plotter.renderer.ResetCameraClippingRange()

    # ------------------------------------------------------------------ networks
    def _network_image(self, scene: Scene, system: System, modes: Modes, indices: Sequence[int],
                       out_dir: Path, names: Mapping[int, str] | None = None) -> tuple[str, str]:
        """The C-alpha trace as a tube, one panel per mode, arrows on every k-th site (k from the size)."""
        pv = self._pv
        from vibra.charts.renders import ColourBar, annotate_render

        positions = positions3(system)
        n = len(positions)
        every = network_arrow_step(n)
        columns = min(len(indices), 3)
        rows = -(-len(indices) // columns)
        plotter = self._plotter((rows, columns))
        extent = float(np.ptp(positions, axis=0).max())
        line = pv.lines_from_points(positions)
        shown = np.arange(0, n, every)
        titles: list[str] = []
        for panel, k in enumerate(indices):
            plotter.subplot(panel // columns, panel % columns)
            motion = np.linalg.norm(displacements3(system, np.asarray(modes.shapes)[:, k]), axis=1)
            trace = line.copy()
            trace["motion"] = motion / max(float(motion.max()), 1e-300)  # the tube coloured by each site's share
            plotter.add_mesh(trace.tube(radius=0.012 * extent, n_sides=12), scalars="motion", cmap="viridis",
                             clim=(0.0, 1.0), show_scalar_bar=False, smooth_shading=True)
            vectors = displacements3(system, np.asarray(modes.shapes)[:, k])[shown]
            size = max(float(np.linalg.norm(vectors, axis=1).max()), 1e-300)
            arrows = [_arrow(pv, positions[i], 0.18 * extent * v / size, 0.0045 * extent)
                      for i, v in zip(shown, vectors) if np.linalg.norm(v) > 0.05 * size]
            if arrows:
                plotter.add_mesh(pv.merge(arrows), color="crimson", smooth_shading=True)
            titles.append(f"{_mode_name(names, k)}: {_frequency_text(scene, modes, k)}")
            self._network_camera(plotter, positions, rows)
        name = f"{scene.name}_modes.png"
        note = f"one arrow every {every} residues" if every > 1 else "one arrow per residue"
        bar = ColourBar("residue's share of the motion |u$_i$| / max |u| (dimensionless)", "viridis")
        write_png(annotate_render(self._snapshot(plotter), grid=(rows, columns), titles=titles,
                                  note=f"{note}, length proportional to the motion", colour_bar=bar), out_dir / name)
        listed = ", ".join(f"{_mode_name(names, k)} ({_frequency_text(scene, modes, k)})" for k in indices)
        return name, (f"{scene.title}: slowest non-rigid modes, {listed}, as arrows on the C-alpha trace "
                      f"({n} residues, tube through the C-alpha atoms coloured by each residue's share of the motion, "
                      f"colour bar below; {note}, length proportional to the motion, the smallest 5% left out)")

    def _network_camera(self, plotter: Any, positions: Any, rows: int, zoom: float = 1.3) -> None:
        """The network camera rule: along the structure's thinnest principal axis, its longest one
        across the panel (the widest projection: a two-lobed protein shows both lobes side by side)."""
        centre = positions.mean(axis=0)
        extent = float(np.ptp(positions, axis=0).max())
        axes = np.linalg.eigh(np.cov((positions - centre).T))[1] if len(positions) >= 3 else np.eye(3)[:, ::-1]
        plotter.camera.focal_point = tuple(centre)
        plotter.camera.position = tuple(centre + 3.0 * extent * axes[:, 0])
        plotter.camera.up = tuple(axes[:, 1])
        plotter.reset_camera()
        plotter.camera.zoom(zoom if rows == 1 else 0.98)  # the tallest structure part stays in view

    def _scalar_network_image(self, scene: Scene, positions: Any, modes: Modes, indices: Sequence[int], out_dir: Path,
                              names: Mapping[int, str] | None) -> tuple[str, str]:
        """A GNM's modes: the C-alpha trace as a tube coloured by each residue's signed amplitude
        u_i / max |u| on a diverging map (the two signs move in opposition), one panel per mode."""
        pv = self._pv
        from vibra.charts.renders import ColourBar, annotate_render

        columns = min(len(indices), 3)
        rows = -(-len(indices) // columns)
        plotter = self._plotter((rows, columns))
        extent = float(np.ptp(positions, axis=0).max())
        line = pv.lines_from_points(positions)
        titles: list[str] = []
        for panel, k in enumerate(indices):
            plotter.subplot(panel // columns, panel % columns)
            shape = np.asarray(modes.shapes)[:, k]
            trace = line.copy()
            trace["amplitude"] = shape / max(float(np.abs(shape).max()), 1e-300)
            plotter.add_mesh(trace.tube(radius=0.015 * extent, n_sides=12), scalars="amplitude", cmap="RdBu_r",
                             clim=(-1.0, 1.0), show_scalar_bar=False, smooth_shading=True, ambient=0.45, diffuse=0.6)
            titles.append(f"{_mode_name(names, k)}: {_frequency_text(scene, modes, k)}")
            self._network_camera(plotter, positions, rows, zoom=1.05)  # no arrows reach out: the whole chain framed
        name = f"{scene.name}_modes.png"
        bar = ColourBar("residue's amplitude u$_i$ / max |u| (dimensionless; the sign is arbitrary per mode)",
                        "RdBu_r", -1.0, 1.0)
        write_png(annotate_render(self._snapshot(plotter), grid=(rows, columns), titles=titles, colour_bar=bar),
                  out_dir / name)
        listed = ", ".join(f"{_mode_name(names, k)} ({_frequency_text(scene, modes, k)})" for k in indices)
        return name, (f"{scene.title}: slowest non-rigid modes, {listed}, of the Gaussian network model (one scalar "
                      f"amplitude per residue) as colours on the C-alpha trace ({len(positions)} residues): red and "
                      "blue move in opposition, white residues are the hinges")

    # ------------------------------------------------------------------ chains
    def _chain_sites(self, system: System) -> NDArray[np.intp]:
        return chain_sites(system.masses)

    def _chain_image(self, scene: Scene, system: System, modes: Modes, indices: Sequence[int],
                     out_dir: Path, names: Mapping[int, str] | None = None) -> tuple[str, str]:
        from vibra.charts.renders import annotate_render

        plotter = self._plotter((len(indices), 1))
        titles = []
        for row, k in enumerate(indices):
            plotter.subplot(row, 0)
            titles.append(self._draw_chain(plotter, scene, system, modes, k, names=names))
        name = f"{scene.name}_modes.png"
        sites = self._chain_sites(system)
        drawn = None
        if len(sites) < system.n_sites:
            drawn = (f"{_count_text(system.n_sites)} sites drawn as {len(sites)} beads "
                     f"(one in {_count_text(int(sites[1] - sites[0]))}, evenly spaced)")
        write_png(annotate_render(self._snapshot(plotter), grid=(len(indices), 1), titles=titles, note=drawn),
                  out_dir / name)
        transverse = scene.system.builder == "beaded_string"
        note = (f"; one site in {sites[1] - sites[0]} shown ({len(sites)} of {system.n_sites}, "
                "evenly spaced)" if len(sites) < system.n_sites else "")
        direction = "across the string (transverse)" if transverse else "along the chain (axial motion)"
        listed = ", ".join(f"{_mode_name(names, k)} ({_frequency_text(scene, modes, k)})" for k in indices)
        return name, (f"{scene.title}: {listed}; one row per mode, arrows {direction}, "
                      f"sphere volume proportional to mass{note}")

    def _draw_chain(self, plotter: Any, scene: Scene, system: System, modes: Modes, k: int,
                    *, phase: float | None = None, names: Mapping[int, str] | None = None) -> str:
        """One row of masses for mode k in the current subplot (displaced when `phase` is given); its title."""
        pv = self._pv
        sites = self._chain_sites(system)
        x = np.asarray(system.positions, dtype=float)[sites, 0]
        width = 10.0
        span = float(x.max() - x.min())
        x = (x - x.min()) / span * width if span > 0 else np.zeros(len(x))
        step = width / max(len(x) - 1, 1)
        masses = np.asarray(system.masses, dtype=float)[sites]
        radii = 0.3 * step * np.cbrt(masses / masses.max())
        transverse = scene.system.builder == "beaded_string"
        shape = displacements3(system, np.asarray(modes.shapes)[:, k])[sites, 1 if transverse else 0]
        size = max(float(np.abs(shape).max()), 1e-300)
        length = (1.2 if transverse else 0.95) * step * shape / size
        offsets = np.zeros((len(x), 3))
        if phase is not None:
            offsets[:, 1 if transverse else 0] = 0.8 * np.cos(phase) * length
        centres = np.column_stack([x, np.zeros(len(x)), np.zeros(len(x))]) + offsets
        line = pv.Line((x[0] - 0.5 * step, 0.0, 0.0), (x[-1] + 0.5 * step, 0.0, 0.0))
        plotter.add_mesh(line.tube(radius=0.05 * step), color="gray")
        cloud = pv.PolyData(centres)
        cloud["radius"] = radii
        spheres = cloud.glyph(geom=pv.Sphere(radius=1.0, theta_resolution=16, phi_resolution=16),
                              scale="radius", orient=False)
        plotter.add_mesh(spheres, color="steelblue", smooth_shading=True)
        # invisible frame so every row spans the same height, arrows or not
        reach = 1.3 * step if transverse else 0.9 * step
        frame = pv.PolyData(np.array([[x[0] - 0.6 * step, -reach, 0.0], [x[-1] + 0.6 * step, reach, 0.0]]))
        plotter.add_mesh(frame, opacity=0.0, render_points_as_spheres=False, point_size=1)
        moving = np.abs(length) > 2e-2 * step
        if phase is None and moving.any():
            count = int(moving.sum())
            if transverse:
                starts = centres[moving]
                directions = np.column_stack([np.zeros(count), length[moving], np.zeros(count)])
            else:
                starts = centres[moving] + np.array([0.0, radii.max() + 0.3 * step, 0.0])
                starts[:, 0] -= 0.5 * length[moving]
                directions = np.column_stack([length[moving], np.zeros((count, 2))])
            arrows = [_arrow(pv, a, d, 0.04 * step) for a, d in zip(starts, directions)]
            plotter.add_mesh(pv.merge(arrows), color="crimson", smooth_shading=True)
        # Parallel projection framed on the row: fit its width to the subplot's aspect ratio.
        rows, columns = plotter.shape
        aspect = (self.window_size[0] / columns) / (self.window_size[1] / rows)
        half_width = 0.5 * (x[-1] - x[0]) + 0.8 * step
        centre = (0.5 * (x[0] + x[-1]), 0.0, 0.0)
        camera = plotter.camera
        scale = max(1.45 * reach, half_width / aspect)
        lifted = (centre[0], 0.22 * scale, 0.0)  # the row sits below the caption line
        camera.parallel_projection = True
        camera.focal_point = lifted
        camera.position = (centre[0], lifted[1], 10.0 * width)
        camera.up = (0.0, 1.0, 0.0)
        camera.parallel_scale = scale
        plotter.renderer.ResetCameraClippingRange()
        return f"{_mode_name(names, k)}: {_frequency_text(scene, modes, k)}"
