"""Building the system a scene describes: scene parameters -> one builder call of vibra.

Builders are looked up in `vibra.scene.BUILD_FUNCTIONS`, a fixed table of (module, function)
inside vibra; nothing from a scene file is imported or executed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vibra.scene import Scene, SceneError, builder_function

__all__ = ["build_system"]


def build_system(scene: Scene) -> Any:
    """The `System` (or, for an oscillator scene, the `Oscillator`) a scene describes.

    The builder validates its arguments as it would in any library call; what it refuses is
    reported as a `SceneError` at the offending key (``file: system.n: n is 1; ...``), so
    ``vibra validate`` (which builds every scene) refuses what ``vibra report`` could not run.

    Raises
    ------
    SceneError
        The builder (or freezing) refused a parameter.
    """
    try:
        return _build(scene)
    except (ValueError, TypeError) as error:
        if isinstance(error, SceneError):
            raise
        message = str(error).replace("; pass symmetrize=True to use (K + K^T) / 2", "; a scene's K must be symmetric")
        first = message.split(" ", 1)[0].split("[", 1)[0]
        key = f"system.{first}" if first in scene.system.parameters else "system"
        raise SceneError(scene.source, key, message) from error


def _build(scene: Scene) -> Any:
    p = dict(scene.system.parameters)
    builder = scene.system.builder
    frozen_sites = p.pop("frozen_sites", None)
    frozen_dofs = p.pop("frozen_dofs", None)
    make = builder_function(builder)
    lists = {k: (np.asarray(v) if isinstance(v, tuple) else v) for k, v in p.items()}
    if builder == "linear_chain":
        mass = lists.pop("mass")
        site, defect = lists.pop("defect_site"), lists.pop("defect_mass")
        if site is not None:
            mass = np.full(p["n"], mass, dtype=float) if np.ndim(mass) == 0 else np.array(mass, dtype=float)
            mass[site] = defect
        system = make(lists.pop("n"), mass=mass, units=scene.units, name=scene.name, **lists)
    elif builder in ("diatomic_chain", "beaded_string"):
        if builder == "diatomic_chain":
            lists["masses"] = tuple(p["masses"])
            if isinstance(p["stiffness"], tuple):
                lists["stiffness"] = tuple(p["stiffness"])
        system = make(units=scene.units, name=scene.name, **lists)
    elif builder == "springs":
        lists.pop("symbols")
        springs = np.asarray(p["springs"], dtype=np.intp).reshape(-1, 2)
        anchors = lists.pop("anchors")
        system = make(lists.pop("positions"), lists.pop("masses"), springs=springs,
                      stiffness=lists.pop("stiffness"),
                      anchors=None if anchors is None else np.asarray(anchors, dtype=np.intp),
                      anchor_stiffness=lists.pop("anchor_stiffness"), units=scene.units,
                      name=scene.name)
    elif builder == "co2":
        system = make(dims=p["dims"])
    elif builder == "h2o":
        system = make()
    elif builder == "double_pendulum":
        system = make(**p)
    elif builder == "matrices":
        system = make(np.asarray(p["M"]), np.asarray(p["K"]), coordinates=p["coordinates"],
                      units=scene.units, name=scene.name)
    elif builder == "oscillator":
        gammas = p["gamma"] if isinstance(p["gamma"], tuple) else (p["gamma"],)
        return tuple(make(p["w0"], g, p["m"]) for g in gammas)
    else:  # pragma: no cover - BUILDERS and BUILD_FUNCTIONS are kept in step
        raise KeyError(builder)
    if frozen_sites or frozen_dofs:
        system = system.freeze(sites=None if not frozen_sites else np.asarray(frozen_sites, dtype=np.intp),
                               dofs=None if not frozen_dofs else np.asarray(frozen_dofs, dtype=np.intp))
    return system


