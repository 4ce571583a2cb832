"""Charts of a scene's normal modes for reports: a stick spectrum, and shapes in generalised coordinates.

Both take the scene (title, kind) and computed result objects and draw only; each returns the
figure and a caption. Write a figure with `vibra.charts.save_figure`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, Sequence

import numpy as np

from vibra._core.text import counted
from vibra.charts._style import new_figure, plain_math

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from vibra.generalized import GeneralizedSystem
    from vibra.modes import Modes

__all__ = ["spectrum_figure", "shapes_figure", "SceneLike"]


class SceneLike(Protocol):
    """What these charts read of a scene (`vibra.pipeline.scene.Scene`, a stage above the charts,
    which they do not import): its kind and its title."""

    @property
    def kind(self) -> str: ...

    @property
    def title(self) -> str: ...


def _frequency_axis(scene: Any, modes: Any) -> tuple[Any, str]:
    from vibra.units import omega_unit_text

    units = modes.units
    if units.time_s is None:
        unit = omega_unit_text(units, stiffness="gamma" if scene.kind == "network" else "k")
        return np.asarray(modes.omega), f"angular frequency $\\omega$ ({unit}, dimensionless)"
    if scene.kind == "molecule":
        return modes.wavenumbers_cm1(), "wavenumber (cm$^{-1}$)"
    return modes.omega_rad_per_s(), "angular frequency $\\omega$ (rad/s)"


def spectrum_figure(scene: SceneLike, modes: Modes) -> tuple[Figure, str]:
    """Stick spectrum of the modes: one unit stick per mode (degenerate modes stack).

    Returns the figure and its caption. The stick height counts modes (no intensity
    model); rigid-body (zero) modes are drawn grey.
    """
    values, label = _frequency_axis(scene, modes)
    zero = modes.zero_modes(1e-6)
    figure, axes = new_figure()
    scale = float(np.abs(values).max()) if len(values) else 1.0
    merged: dict[float, int] = {}
    for v in np.asarray(values):
        key = round(float(v) / max(scale, 1e-300), 6) * scale
        merged[key] = merged.get(key, 0) + 1
    shown = [v for v in merged if abs(v) > 1e-6 * scale]
    digits = 4  # more significant digits only where distinct sticks would read alike
    while digits < 10 and len({f"{v:.{digits}g}" for v in shown}) < len(shown):
        digits += 1
    labels = []
    for v, count in merged.items():
        is_zero = abs(v) <= 1e-6 * scale
        axes.vlines(v, 0, count, color="0.6" if is_zero else "C0", linewidth=2.0)
        if len(merged) <= 16 and not is_zero:
            labels.append(axes.annotate(f"{v:.{digits}g}", (v, count), textcoords="offset points", xytext=(0, 4),
                                        ha="center", fontsize=10))
    axes.set_xlabel(label)
    axes.set_ylabel("number of modes")
    axes.margins(x=0.06)  # the outermost labels stay inside the axes
    axes.yaxis.get_major_locator().set_params(integer=True)
    axes.set_title(f"{scene.title}: {counted(modes.n_modes, 'mode')}")
    axes.set_ylim(0, max(merged.values()) + 0.7)
    _stagger_labels(figure, axes, labels)
    n_zero = int(zero.sum())
    caption = (f"{scene.title}: stick spectrum of {counted(modes.n_modes, 'computed mode')} ({plain_math(label)}); "
               f"stick height = number of modes at that frequency"
               + (f", {counted(n_zero, 'zero (rigid-body) mode')} in grey" if n_zero else ""))
    return figure, caption


def _stagger_labels(figure: Any, axes: Any, labels: Sequence[Any]) -> None:
    """Lift stick labels that would overlap a neighbour's, and make room for them.

    Labels are taken left to right; one whose horizontal extent (in pixels) meets an
    earlier label at the same stick height and level goes up one level (14 points). The
    y range then grows until the highest label fits inside the axes.
    """
    if not labels:
        return
    renderer = figure.canvas.get_renderer()
    placed: list[tuple[float, float, float, int]] = []  # (left, right, stick height, level)
    for label in sorted(labels, key=lambda a: a.xy[0]):
        box = label.get_window_extent(renderer)
        level = 0
        while any(level == lv and height == label.xy[1] and box.x0 < right + 2 and left < box.x1 + 2
                  for left, right, height, lv in placed):
            level += 1
        label.xyann = (0, 4 + 14 * level)
        placed.append((box.x0, box.x1, label.xy[1], level))
    for _ in range(3):  # a taller y range lowers the labels: repeat until they fit
        top = max(label.get_window_extent(renderer).y1 for label in labels)
        limit = axes.get_window_extent(renderer).y1
        if top <= limit - 4:
            break
        low, high = axes.get_ylim()
        pixels_per_unit = axes.get_window_extent(renderer).height / (high - low)
        axes.set_ylim(low, high + (top - limit + 8) / pixels_per_unit)


def shapes_figure(scene: SceneLike, system: GeneralizedSystem, modes: Modes, indices: Sequence[int]
                  ) -> tuple[Figure, str]:
    """Bar chart of mode shapes in generalised coordinates (one panel per mode)."""
    n = len(indices)
    figure, axes = new_figure(1, n, figsize=(4.0 * n + 1.0, 4.5), squeeze=False)
    names = [system.labels[i] for i in system.free_dofs]
    for panel, k in zip(axes[0], indices):
        shape = np.asarray(modes.shapes)[:, k]
        shape = shape / np.abs(shape).max()
        panel.bar(range(len(shape)), shape, color=["C0" if s >= 0 else "C3" for s in shape])
        panel.set_xticks(range(len(shape)), names)
        panel.axhline(0.0, color="black", linewidth=0.8)
        freq = modes.frequencies_hz()[k] if modes.units.time_s is not None else modes.omega[k]
        unit = "Hz" if modes.units.time_s is not None else "√(k/m) (dimensionless ω)"
        panel.set_title(f"mode {k}: {freq:.4g} {unit}")
        panel.set_xlabel("generalised coordinate")
        panel.set_ylabel("relative amplitude (largest = 1)")
    caption = (f"{scene.title}: shapes of modes {', '.join(str(k) for k in indices)} in generalised "
               "coordinates, normalised to a largest component of 1")
    return figure, caption
