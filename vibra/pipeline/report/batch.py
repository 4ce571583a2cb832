"""`vibra report`: scene files -> PNG images, ``summary.json`` and ``index.html``, in batch.

Each scene runs isolated: it is validated, planned (`vibra.pipeline.plan`) and executed in the work
folder of its process, ``DIR/.work/<pid>/<scene>/``; its images are moved into ``DIR`` (one
atomic ``os.replace`` per file) only after every step succeeded, so a failing or interrupted
scene leaves no partial output and ``DIR`` never holds a half-written file. A failing scene
does not stop the others; the returned `BatchResult` (and the CLI's exit code and final
table) say which failed and why, each in one line.

A run holds the folder's lock (`vibra.pipeline.report.folder.FolderLock`) from start to end, first
removes what killed runs left (`clean_stale`), and finally merges its scenes into the
folder's ``summary.json`` and ``index.html`` (`vibra.pipeline.report.pages`). A finished scene records
its skip key in ``DIR/.vibra/<scene>.json``; a scene whose key is unchanged and whose outputs
are still sound (`output_is_sound`) is skipped on the next run unless ``force=True``. The key
hashes the scene file, vibra's version, vibra's code (`code_hash`) and the options.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import shutil
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Sequence

from vibra._core.cores import available_cores
from vibra._core.filesystem import TargetRefused, check_target, protected_inputs
from vibra.cluster import ClientOption, check_client, connect, run_tasks
from vibra.pipeline.report.folder import (
    MANIFESTS, FolderLock, check_out_dir, clean_stale, code_hash, output_is_sound, work_folder, write_manifest,
)
from vibra.pipeline.report.outcome import BatchResult, ProgressBar, SceneOutcome
from vibra.pipeline.report.pages import merged_outcomes, write_index, write_summary

__all__ = ["run_scene", "report", "available_cores", "missing_paths"]


def missing_paths(paths: Sequence[str | os.PathLike[str]]) -> list[str]:
    """The entries of `paths` that do not exist (a dangling symlink counts as missing)."""
    return [str(p) for p in paths if not os.path.exists(p)]


def _input_hash(data: bytes, window_size: Sequence[int] | None) -> str:
    from vibra import __version__

    digest = hashlib.sha256()
    digest.update(data)
    options = {"window_size": list(window_size) if window_size else None}
    digest.update(f"\0vibra {__version__}\0code {code_hash()}\0options {json.dumps(options)}".encode())
    return digest.hexdigest()


def _manifest_path(out_dir: Path, name: str) -> Path:
    return out_dir / MANIFESTS / f"{name}.json"


def _stored_outcome(out_dir: Path, name: str, digest: str) -> SceneOutcome | None:
    """The stored outcome of an unchanged, finished scene whose outputs are still sound."""
    try:
        data = json.loads(_manifest_path(out_dir, name).read_text(encoding="utf-8"))
        outcome = SceneOutcome.from_json(data)
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    if outcome.status != "ok" or outcome.input_hash != digest:
        return None
    if not all(output_is_sound(out_dir / f) for f in outcome.outputs):
        return None  # removed, emptied or truncated since: redo
    return outcome


def _failed(source: Path, name: str, title: str, start: float, error: str, detail: str = "",
            kind: str = "") -> SceneOutcome:
    return SceneOutcome(source=str(source), name=name, title=title, status="failed", error=error,
                        seconds=time.perf_counter() - start, detail=detail, kind=kind)


def _numbers(scene: Any, modes: Any) -> dict[str, Any]:
    """The modes' frequencies as numbers with their units, for the outcome."""
    if modes is None:
        return {}
    import numpy as np

    values: dict[str, Any] = {"omega": tuple(float(w) for w in np.asarray(modes.omega)),
                              "omega_unit": str(modes.units.omega)}
    if modes.units.time_s is not None:
        molecule = scene.kind == "molecule"
        extra = modes.wavenumbers_cm1() if molecule else modes.frequencies_hz()
        values.update(frequency=tuple(float(f) for f in np.asarray(extra)),
                      frequency_unit="cm^-1" if molecule else "Hz")
    return values


def _publish(source: str, staging: Path, target: Path, outputs: Sequence[str]) -> None:
    """Move the staged outputs into `target`; every destination is checked by the one rule of
    `vibra._core.filesystem.check_target` (a regular file or a new name, never an input of the run) before any moves."""
    from vibra.pipeline.scene import SceneError

    def checked(output: str) -> Path:
        try:
            return check_target(target / output)
        except TargetRefused as error:
            raise SceneError(source, "name", f"this scene's output file {error}; remove or rename what is "
                             "there") from None

    for output in outputs:
        checked(output)
    for output in outputs:  # each rename is atomic (modes set by vibra._core.filesystem)
        os.replace(staging / output, checked(output))


# ---------------------------------------------------------------------- one scene
def run_scene(path: str | os.PathLike[str], out_dir: str | os.PathLike[str], *, force: bool = False,
              window_size: Sequence[int] | None = None,
              on_step: Callable[[str], None] | None = None) -> SceneOutcome:
    """Validate, plan and execute one scene file; never raises for a bad scene.

    Parameters
    ----------
    path : path-like
        The scene file.
    out_dir : path-like
        Output folder; images land there only when the whole scene succeeded.
    force : bool
        Redo the scene even when its inputs are unchanged since a successful run.
    window_size : (int, int), optional
        Override the scene's image size in pixels.
    on_step : callable, optional
        Called with each step name (progress).

    Returns
    -------
    SceneOutcome
        ``status="failed"`` with a one-line error for an invalid scene or a failing step
        (an unexpected exception also keeps its traceback in ``detail``).
    """
    from vibra.pipeline.plan import execute, make_plan
    from vibra.pipeline.scene import Scene, SceneError, parse_scene_text, read_scene_bytes, scene_inputs

    start = time.perf_counter()
    source = Path(path)
    target = Path(out_dir)
    name, title = source.stem, source.stem
    try:
        data = read_scene_bytes(source)
        scene = Scene.from_dict(parse_scene_text(data, str(source)), source=str(source))
    except SceneError as error:
        return _failed(source, name, title, start, str(error))
    name, title = scene.name, scene.title
    if window_size is not None:
        scene = dataclasses.replace(scene, draw=dataclasses.replace(
            scene.draw, window_size=(int(window_size[0]), int(window_size[1]))))
    digest = _input_hash(data, window_size)
    if not force:
        stored = _stored_outcome(target, name, digest)
        if stored is not None:
            return dataclasses.replace(stored, status="skipped", seconds=time.perf_counter() - start)
    work = work_folder(target) / name
    staging, scratch = work / "out", work / "scratch"
    try:
        shutil.rmtree(work, ignore_errors=True)
        staging.mkdir(parents=True, exist_ok=True)
        scratch.mkdir(parents=True, exist_ok=True)
        with protected_inputs(scene_inputs(scene)):  # no output over the scene or its data files
            result = execute(make_plan(scene), staging, scratch, on_step=on_step)
            _publish(str(source), staging, target, result.outputs)
        outcome = SceneOutcome(source=str(source), name=name, title=title, status="ok",
                               outputs=result.outputs, captions=result.captions, steps=result.records,
                               frequencies=result.frequencies, seconds=time.perf_counter() - start,
                               input_hash=digest, kind=scene.kind, **_numbers(scene, result.modes))
        write_manifest(target, name, json.dumps(outcome.as_json(), indent=1, allow_nan=False))
        return outcome
    except SceneError as error:  # a refused parameter or a failing step: one line, at its key
        _manifest_path(target, name).unlink(missing_ok=True)
        return _failed(source, name, title, start, str(error), kind=scene.kind)
    except OSError as error:  # the output folder: full, removed, not writable
        _manifest_path(target, name).unlink(missing_ok=True)
        where = f" ({error.filename})" if error.filename else ""
        return _failed(source, name, title, start, f"{source}: cannot write the outputs{where}: "
                       f"{error.strerror or error}; check the output folder", kind=scene.kind)
    except Exception as error:  # a bug: one line here, the traceback in `detail` (--debug)
        _manifest_path(target, name).unlink(missing_ok=True)
        text = " ".join(f"{type(error).__name__}: {error}".split())[:300]
        return _failed(source, name, title, start, f"{source}: internal error ({text}); rerun with --debug "
                       "for the traceback and report it", traceback.format_exc(), scene.kind)
    finally:
        shutil.rmtree(work, ignore_errors=True)
        try:
            work.parent.rmdir()  # this process's folder, once its last scene is done
        except OSError:
            pass


def _die_with_parent(parent: int) -> None:
    """Worker initializer: end this worker when the report process dies (Linux), so a killed
    report leaves no orphan still writing into the folder (its temporary files are then stale)."""
    import ctypes
    import signal

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the worker ends after its current scene
        pass
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)


def _worker(path: str, out_dir: str, force: bool, window_size: Sequence[int] | None) -> SceneOutcome:
    return run_scene(path, out_dir, force=force, window_size=window_size)


# ---------------------------------------------------------------------- batch
def report(paths: Sequence[str | os.PathLike[str]], out_dir: str | os.PathLike[str] = "plots", *,
           jobs: int = 1, force: bool = False, window_size: Sequence[int] | None = None,
           progress: bool = True, wait: float = 60.0, scheduler: ClientOption = None, timeout: float = 10.0) -> BatchResult:
    """Render every scene in `paths` (files or folders of ``*.toml``) into `out_dir`.

    Parameters
    ----------
    paths : sequence of path-like
        Scene files or folders; every one must exist.
    out_dir : path-like
        Output folder (created); gets the images, ``summary.json`` and ``index.html``, which
        list this run's scenes merged with the folder's earlier ones.
    jobs : int
        Worker processes (1: run in this process).
    force : bool
        Redo scenes whose inputs are unchanged since their last successful run, and write into an
        existing folder that vibra did not write (by default `out_dir` must be new, empty or
        vibra's own: `vibra._core.filesystem.claim_out_folder`).
    window_size : (int, int), optional
        Override every scene's image size in pixels.
    progress : bool
        Show a progress bar on stderr.
    wait : float
        Seconds to wait for another run that holds the folder's lock, in s.
    scheduler : None, "local", str or distributed.Client
        Run each scene as a Dask task (`vibra.cluster.connect`): ``"local"`` (a local cluster of
        `jobs` worker processes), a scheduler address or a ``Client``; the outputs are those of
        the local run. On a remote cluster `out_dir` must be a folder every worker can write (a
        shared file system). The scheduler is reached before the folder is touched.
    timeout : float
        Seconds to wait for a scheduler address to answer.

    Returns
    -------
    BatchResult

    Raises
    ------
    FileNotFoundError
        A path does not exist (nothing is touched).
    ValueError
        `jobs` < 1 or `paths` holds no scene file.
    NotADirectoryError, vibra._core.filesystem.TargetRefused
        `out_dir` is not a writable folder report may fill (`check_out_dir`).
    FolderBusy
        Another run held the folder for longer than `wait`.
    """
    from vibra.pipeline.scene import find_scene_files

    if isinstance(jobs, bool) or not isinstance(jobs, int):
        raise TypeError(f"jobs must be an int, got {type(jobs).__name__}")
    if jobs < 1:
        raise ValueError(f"jobs is {jobs}; expected jobs >= 1")
    missing = missing_paths(paths)
    if missing:
        raise FileNotFoundError(f"{missing[0]}: no such file or folder; expected scene files (*.toml) or folders "
                                "of them (nothing was written)")
    files = find_scene_files(list(paths))
    if not files:
        raise ValueError(f"paths holds no scene file (*.toml): {[str(p) for p in paths]}")
    if scheduler is not None:
        check_client(scheduler, "scheduler")
    cluster = contextlib.nullcontext() if scheduler is None else connect(scheduler, n_workers=jobs, timeout=timeout)
    with cluster as client:  # an unreachable scheduler fails here, before the folder is touched
        target = check_out_dir(out_dir, inputs=files, force=force)  # report's files never replace a scene file
        with FolderLock(target, wait=wait):
            clean_stale(target)
            try:
                result = _run_all(files, target, jobs=jobs, force=force, window_size=window_size,
                                  progress=progress, client=client)
                merged = merged_outcomes(target, result.outcomes)
                with protected_inputs(files):  # summary.json and index.html never replace a scene file
                    write_summary(result, merged)
                    write_index(result, merged)
            finally:  # also when interrupted (Ctrl-C, SIGTERM): what finished processes left goes,
                # and this process's own folder (a signal may have cut its scene's own clean-up short)
                shutil.rmtree(work_folder(target), ignore_errors=True)
                clean_stale(target)
                try:
                    (target / ".work").rmdir()  # every scene is done; removed only when empty
                except OSError:
                    pass
    return result


def _run_all(files: Sequence[Path], target: Path, *, jobs: int, force: bool, window_size: Sequence[int] | None,
             progress: bool, client: Any = None) -> BatchResult:
    start = time.perf_counter()
    bar = ProgressBar(len(files), enabled=progress)
    outcomes: list[SceneOutcome | None] = [None] * len(files)
    names = _claim_names(files)
    pending = []
    for i, file in enumerate(files):
        duplicate = names[i]
        if duplicate is not None:
            outcomes[i] = SceneOutcome(source=str(file), name=file.stem, title=file.stem, status="failed",
                                       error=duplicate)
            bar.update(outcomes[i])  # type: ignore[arg-type]
        else:
            pending.append(i)
    size = None if window_size is None else (int(window_size[0]), int(window_size[1]))
    if client is not None:
        _run_on_dask(client, files, pending, outcomes, bar, target, force, size)
        jobs = len(client.scheduler_info()["workers"])
    elif jobs == 1 or len(pending) <= 1:
        for i in pending:
            outcomes[i] = run_scene(files[i], target, force=force, window_size=size)
            bar.update(outcomes[i])  # type: ignore[arg-type]
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # spawn: a fresh interpreter per worker (VTK and forked GL state do not mix).
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(jobs, len(pending)), mp_context=context,
                                 initializer=_die_with_parent, initargs=(os.getpid(),)) as pool:
            futures = {pool.submit(_worker, str(files[i]), str(target), force, size): i for i in pending}
            try:
                for future in as_completed(futures):
                    i = futures[future]
                    try:
                        outcomes[i] = future.result()
                    except Exception as error:  # a worker that died (e.g. killed by the OS)
                        outcomes[i] = SceneOutcome(source=str(files[i]), name=files[i].stem,
                                                   title=files[i].stem, status="failed",
                                                   error=f"{files[i]}: worker failed: {error!r}")
                    bar.update(outcomes[i])  # type: ignore[arg-type]
            except KeyboardInterrupt:
                for future in futures:
                    future.cancel()
                raise
    return BatchResult(out_dir=target, outcomes=tuple(o for o in outcomes if o is not None),
                       seconds=time.perf_counter() - start, jobs=jobs)


def _run_on_dask(client: Any, files: Sequence[Path], pending: Sequence[int], outcomes: list[SceneOutcome | None],
                 bar: ProgressBar, target: Path, force: bool, size: tuple[int, int] | None) -> None:
    """Each pending scene as one Dask task (`run_scene` on a worker); a lost task is a failed scene."""
    def finished(k: int, outcome: SceneOutcome) -> None:
        outcomes[pending[k]] = outcome
        bar.update(outcome)

    _, failures = run_tasks(client, _worker, [(str(files[i]), str(target), force, size) for i in pending],
                            labels=[str(files[i]) for i in pending], on_result=finished, name="vibra-report")
    for failure in failures:  # run_scene never raises for a bad scene: the worker itself failed
        i = pending[failure.index]
        lost = SceneOutcome(source=str(files[i]), name=files[i].stem, title=files[i].stem, status="failed",
                            error=f"{files[i]}: worker failed: {failure.error!r}")
        outcomes[i] = lost
        bar.update(lost)


def _claim_names(files: Sequence[Path]) -> list[str | None]:
    """An error for every file whose scene name repeats an earlier one (None otherwise).

    The name is read cheaply (a valid scene's ``name`` key or its file stem), through the
    bounded reader (no FIFO or device is opened); two scenes with one name would write the
    same output files.
    """
    from vibra.pipeline.scene import SceneError, parse_scene_text, read_scene_bytes

    seen: dict[str, Path] = {}
    errors: list[str | None] = []
    for file in files:
        name = file.stem
        try:
            data = parse_scene_text(read_scene_bytes(file), str(file))
            if isinstance(data.get("name"), str):
                name = data["name"]
        except SceneError:
            pass
        if name in seen:
            errors.append(f"{file}: name: scene name {name!r} is already used by {seen[name]}; "
                          "outputs would overwrite each other")
        else:
            seen[name] = file
            errors.append(None)
    return errors
