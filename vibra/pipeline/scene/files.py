"""Data files a scene names (an ``.xyz`` molecule, a ``.pdb`` structure): inside the scene's folder only.

A scene may name a file beside it (``xyz = "ethanol.xyz"``, ``pdb = "1ubi.pdb"``). The path is
taken relative to the scene file's folder and resolved (``..`` and symlinks followed); a path
that then leaves that folder is refused, so a scene can read nothing outside its own folder.
The file must be a regular file of at most `MAX_DATA_BYTES`; `read_scene_data` reads it once,
with that cap, so what was checked is what is parsed.
"""

from __future__ import annotations

import functools
import os
import stat
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from vibra.pipeline.scene.specs import SceneError

if TYPE_CHECKING:
    from vibra.crystals.phonopy_files import PhonopyYamlSummary
# (a `Scene` is typed Any here: the scene package imports this module)

__all__ = ["MAX_DATA_BYTES", "DATA_FILE_KEYS", "scene_data_path", "read_scene_data", "scene_inputs"]

#: Keys of ``[system]`` that name a data file beside the scene (the run's inputs with the scene
#: file itself: no file vibra writes may replace them, see `vibra._core.filesystem.check_target`).
DATA_FILE_KEYS: tuple[str, ...] = ("xyz", "pdb", "file", "force_constants_file", "force_sets_file", "born_file")  # (the last four: crystal scenes' phonopy files)

#: Largest data file a scene may name, in bytes (16 MiB: a 100,000-atom PDB file is about 8 MiB).
MAX_DATA_BYTES = 16 << 20


def scene_data_path(source: str, key: str, name: str) -> Path:
    """The resolved path of the data file `name` that the scene `source` names at `key`.

    Raises
    ------
    SceneError
        An absolute path, a path (or symlink) that leads outside the scene's folder, a missing
        file, or something that is not a regular file.
    """
    if not name or Path(name).is_absolute():
        raise SceneError(source, key, f"is {name!r}; give a file name relative to the scene's folder "
                         "(the file must lie inside that folder)")
    folder = Path(source).parent.resolve()
    path = (folder / name).resolve()
    if path != folder and folder not in path.parents:
        raise SceneError(source, key, f"{name!r} leads outside the scene's folder ({folder}); a scene reads "
                         "only files inside its own folder (symlinks are followed before this check)")
    try:
        info = os.stat(path)
    except OSError:
        raise SceneError(source, key, f"{name!r}: file not found beside the scene (in {folder})") from None
    if not stat.S_ISREG(info.st_mode):
        raise SceneError(source, key, f"{name!r} is not a regular file")
    if info.st_size > MAX_DATA_BYTES:
        raise SceneError(source, key, f"{name!r} is {info.st_size} bytes; a scene's data file may hold at most "
                         f"{MAX_DATA_BYTES} bytes")
    return path


def read_scene_data(source: str, key: str, name: str) -> str:
    """The text of the data file `name` (checked by `scene_data_path`), read with the size cap.

    Raises
    ------
    SceneError
        As `scene_data_path`, or unreadable / not UTF-8 text.
    """
    path = scene_data_path(source, key, name)
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        try:
            if not stat.S_ISREG(os.fstat(descriptor).st_mode):
                raise SceneError(source, key, f"{name!r} is not a regular file")
            with os.fdopen(os.dup(descriptor), "rb") as handle:
                data = handle.read(MAX_DATA_BYTES + 1)
        finally:
            os.close(descriptor)
    except OSError as error:
        raise SceneError(source, key, f"{name!r}: cannot read ({error.strerror})") from None
    if len(data) > MAX_DATA_BYTES:
        raise SceneError(source, key, f"{name!r} holds more than {MAX_DATA_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError(source, key, f"{name!r} is not UTF-8 text") from None


def scene_inputs(scene: Any) -> tuple[Path, ...]:
    """The files a scene's run reads: the scene file and every data file it names (`DATA_FILE_KEYS`).

    Missing or refused files are left out (the build reports them at their key).
    """
    paths = [Path(scene.source)] if scene.source and os.path.lexists(scene.source) else []
    for key in DATA_FILE_KEYS:
        name = scene.system.parameters.get(key)
        if isinstance(name, str):
            try:
                paths.append(scene_data_path(scene.source, f"system.{key}", name))
            except SceneError:
                pass
    return tuple(paths)


@functools.lru_cache(maxsize=32)
def _yaml_summary(path: str, mtime_ns: int, size: int) -> PhonopyYamlSummary:
    from vibra.crystals.phonopy_files import check_phonopy_yaml

    return check_phonopy_yaml(path)


def phonopy_yaml_summary(source: str, name: str, key: str = "system.file") -> PhonopyYamlSummary:
    """`vibra.crystals.phonopy_files.check_phonopy_yaml` of the phonopy yaml `name` beside the scene
    `source`, read once per version of the file (a scene is loaded, validated and planned: one
    parse); a refusal names `key`.

    Raises
    ------
    SceneError
        The path's refusals (`scene_data_path`), or a yaml that is not whole.
    """
    path = scene_data_path(source, key, name)
    info = path.stat()
    try:
        return _yaml_summary(str(path), info.st_mtime_ns, info.st_size)
    except ValueError as error:
        raise SceneError(source, key, f"{name!r}: {str(error).removeprefix(f'{path}: ')}") from None


def check_phonopy_scene_files(source: str, params: Mapping[str, Any]) -> dict[str, Path | None]:
    """A phonopy crystal scene's files (``system.file``, ``system.force_constants_file``,
    ``system.force_sets_file``, ``system.born_file``), each inside the scene's folder and whole (`vibra.crystals`'s
    checks), each refusal at its own key; returns key -> resolved path (None where not given).

    Raises
    ------
    SceneError
        A path outside the folder, a missing or special file, a file that is cut or damaged
        (the key, the file, the line and what is missing), both extra files given.
    """
    from vibra.crystals.phonopy_files import check_force_constants_file, check_force_sets_file

    paths: dict[str, Path | None] = {}
    for key in ("file", "force_constants_file", "force_sets_file", "born_file"):  # a BORN file is checked against the crystal
        name = params.get(key)
        paths[key] = None if name is None else scene_data_path(source, f"system.{key}", name)
    if paths["force_constants_file"] is not None and paths["force_sets_file"] is not None:
        raise SceneError(source, "system.force_sets_file", "is given with system.force_constants_file; give one of "
                         "them (force constants, or the forces phonopy makes them from)")
    n_supercell = None
    if paths["file"] is not None:
        found = phonopy_yaml_summary(source, params["file"])
        n_supercell = found.n_supercell
        if not (found.force_constants or found.forces) and paths["force_constants_file"] is None \
                and paths["force_sets_file"] is None:
            raise SceneError(source, "system.file", f"{params['file']!r} holds no force constants and no forces; name "
                             "its FORCE_CONSTANTS file (system.force_constants_file) or its FORCE_SETS file "
                             "(system.force_sets_file)")
    for key, check in (("force_constants_file", check_force_constants_file), ("force_sets_file", check_force_sets_file)):
        path = paths[key]
        if path is None:
            continue
        try:
            check(path, n_supercell)
        except ValueError as error:
            raise SceneError(source, f"system.{key}", f"{params[key]!r}: {str(error).removeprefix(f'{path}: ')}") \
                from None
    return paths
