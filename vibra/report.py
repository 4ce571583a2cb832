"""`vibra report`: scene files -> PNG images, ``summary.json`` and ``index.html``, in batch.

Each scene runs isolated: it is validated, planned (`vibra.plan`) and executed in its own
work folder ``DIR/.work/<scene>-<pid>/``; its images are moved into ``DIR`` (one atomic
``os.replace`` per file) only after every step succeeded, so a failing or interrupted
scene leaves no partial output and ``DIR`` never holds a half-written file. A failing
scene does not stop the others; the returned `BatchResult` (and the CLI's exit code and
final table) say which failed and why. A finished scene records the hash of its inputs in
``DIR/.vibra/<scene>.json``; an unchanged scene is skipped on the next run unless
``force=True``.
"""

from __future__ import annotations

import hashlib
import html
import json
import os
import shutil
import sys
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from vibra._io import atomic_write_text
from vibra.charts.modes import shapes_figure, spectrum_figure

__all__ = [
    "SceneOutcome", "BatchResult", "run_scene", "report", "atomic_write_text",
    "write_summary", "write_index", "spectrum_figure", "shapes_figure", "ProgressBar",
]

_MANIFESTS = ".vibra"
_WORK = ".work"


@dataclass(frozen=True)
class SceneOutcome:
    """What happened to one scene.

    Attributes
    ----------
    source : str
        The scene file.
    name : str
        The scene name (file stem when the file could not be read).
    title : str
        Its title.
    status : str
        ``"ok"``, ``"skipped"`` (unchanged since the last successful run) or ``"failed"``.
    error : str
        Why it failed ("" otherwise).
    outputs : tuple of str
        Files written, relative to the output folder.
    captions : tuple of str
        One caption per output.
    steps : tuple of dict-free records
        `vibra.plan.StepRecord` per executed step.
    frequencies : tuple of str
        Lines of the frequency table.
    seconds : float
        Wall time of the scene, in s.
    input_hash : str
        SHA-256 of the scene file and vibra's version.
    """

    source: str
    name: str
    title: str
    status: str
    error: str = ""
    outputs: tuple[str, ...] = ()
    captions: tuple[str, ...] = ()
    steps: tuple[Any, ...] = ()
    frequencies: tuple[str, ...] = ()
    seconds: float = 0.0
    input_hash: str = ""

    def as_json(self) -> dict[str, Any]:
        """JSON-ready description (used in ``summary.json`` and the manifests)."""
        return {
            "source": self.source, "name": self.name, "title": self.title, "status": self.status,
            "error": self.error, "outputs": list(self.outputs), "captions": list(self.captions),
            "steps": [{"name": s.name, "what": s.what, "seconds": s.seconds, "solver": s.solver,
                       "accuracy": s.accuracy, "outputs": list(s.outputs)} for s in self.steps],
            "frequencies": list(self.frequencies), "seconds": self.seconds,
            "input_hash": self.input_hash,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SceneOutcome:
        """Rebuild an outcome stored by `as_json` (steps come back as `StepRecord`)."""
        from vibra.plan import StepRecord

        steps = tuple(StepRecord(name=s["name"], what=s["what"], seconds=float(s["seconds"]),
                                 solver=s.get("solver"), accuracy=s.get("accuracy"),
                                 outputs=tuple(s.get("outputs", ()))) for s in data.get("steps", ()))
        return cls(source=data["source"], name=data["name"], title=data["title"], status=data["status"],
                   error=data.get("error", ""), outputs=tuple(data.get("outputs", ())),
                   captions=tuple(data.get("captions", ())), steps=steps,
                   frequencies=tuple(data.get("frequencies", ())), seconds=float(data.get("seconds", 0.0)),
                   input_hash=data.get("input_hash", ""))


@dataclass(frozen=True)
class BatchResult:
    """The outcome of `report`.

    Attributes
    ----------
    out_dir : Path
        The output folder.
    outcomes : tuple of SceneOutcome
        One per scene file, in the order given.
    seconds : float
        Wall time of the batch, in s.
    jobs : int
        Worker processes used.
    """

    out_dir: Path
    outcomes: tuple[SceneOutcome, ...]
    seconds: float
    jobs: int

    @property
    def failed(self) -> tuple[SceneOutcome, ...]:
        """The scenes that failed."""
        return tuple(o for o in self.outcomes if o.status == "failed")

    @property
    def n_images(self) -> int:
        """Number of PNG and GIF files produced or kept."""
        return sum(1 for o in self.outcomes for f in o.outputs if f.endswith((".png", ".gif")))

    def table(self) -> str:
        """The final table: scene, status, time, images, and the error of failed scenes."""
        width = max([len(o.name) for o in self.outcomes] + [5])
        lines = [f"{'scene':<{width}}  {'status':<7}  {'time/s':>7}  {'files':>5}  error"]
        for o in self.outcomes:
            lines.append(f"{o.name:<{width}}  {o.status:<7}  {o.seconds:>7.2f}  {len(o.outputs):>5}  "
                         f"{o.error.splitlines()[0] if o.error else ''}")
        lines.append(f"{len(self.outcomes)} scene(s), {len(self.failed)} failed, {self.n_images} image(s), "
                     f"{self.seconds:.1f} s with {self.jobs} job(s)")
        return "\n".join(lines)


def _input_hash(path: Path, window_size: Sequence[int] | None) -> str:
    from vibra import __version__

    digest = hashlib.sha256()
    digest.update(path.read_bytes())
    digest.update(f"\0vibra {__version__}\0{list(window_size) if window_size else None}".encode())
    return digest.hexdigest()


def _manifest_path(out_dir: Path, name: str) -> Path:
    return out_dir / _MANIFESTS / f"{name}.json"


def _stored_outcome(out_dir: Path, name: str, digest: str) -> SceneOutcome | None:
    """The stored outcome of an unchanged, finished scene whose outputs still exist."""
    try:
        data = json.loads(_manifest_path(out_dir, name).read_text(encoding="utf-8"))
        outcome = SceneOutcome.from_json(data)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if outcome.status != "ok" or outcome.input_hash != digest:
        return None
    if not all((out_dir / f).is_file() for f in outcome.outputs):
        return None
    return outcome


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
        ``status="failed"`` with the error message for an invalid scene or a failing step.
    """
    import dataclasses

    from vibra.plan import execute, make_plan
    from vibra.scene import SceneError, load_scene

    start = time.perf_counter()
    source = Path(path)
    target = Path(out_dir)
    name, title = source.stem, source.stem
    try:
        scene = load_scene(source)
    except SceneError as error:
        return SceneOutcome(source=str(source), name=name, title=title, status="failed", error=str(error),
                            seconds=time.perf_counter() - start)
    name, title = scene.name, scene.title
    if window_size is not None:
        scene = dataclasses.replace(scene, draw=dataclasses.replace(
            scene.draw, window_size=(int(window_size[0]), int(window_size[1]))))
    digest = _input_hash(source, window_size)
    if not force:
        stored = _stored_outcome(target, name, digest)
        if stored is not None:
            return dataclasses.replace(stored, status="skipped", seconds=time.perf_counter() - start)
    work_root = target / _WORK
    for stale in work_root.glob(f"{name}-*"):  # left by an interrupted run of this scene
        if stale.name[len(name) + 1:].isdigit():  # not another scene's ("co2" vs "co2-axial-7")
            shutil.rmtree(stale, ignore_errors=True)
    work = work_root / f"{name}-{os.getpid()}"
    staging, scratch = work / "out", work / "scratch"
    staging.mkdir(parents=True, exist_ok=True)
    scratch.mkdir(parents=True, exist_ok=True)
    try:
        result = execute(make_plan(scene), staging, scratch, on_step=on_step)
        for output in result.outputs:  # publish: each rename is atomic (modes set by vibra._io)
            os.replace(staging / output, target / output)
        outcome = SceneOutcome(source=str(source), name=name, title=title, status="ok",
                               outputs=result.outputs, captions=result.captions, steps=result.records,
                               frequencies=result.frequencies, seconds=time.perf_counter() - start,
                               input_hash=digest)
        atomic_write_text(_manifest_path(target, name), json.dumps(outcome.as_json(), indent=1))
        return outcome
    except Exception as error:  # a failing scene must not stop the batch
        _manifest_path(target, name).unlink(missing_ok=True)
        if isinstance(error, SceneError):  # a builder refused a parameter: one line, at its key
            text = str(error)
        else:
            text = f"{source}: {type(error).__name__}: {error}\n" + traceback.format_exc(limit=-3)
        return SceneOutcome(source=str(source), name=name, title=title, status="failed", error=text,
                            seconds=time.perf_counter() - start)
    finally:
        shutil.rmtree(work, ignore_errors=True)  # the .work root stays: other scenes may be starting


def _worker(path: str, out_dir: str, force: bool, window_size: Sequence[int] | None) -> SceneOutcome:
    return run_scene(path, out_dir, force=force, window_size=window_size)


# ---------------------------------------------------------------------- progress
class ProgressBar:
    """A small text progress bar on a stream (stderr by default); a line per scene off a tty."""

    def __init__(self, total: int, *, stream: Any = None, enabled: bool = True) -> None:
        self.total = total
        self.done = 0
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def update(self, outcome: SceneOutcome) -> None:
        """Count one finished scene and redraw."""
        self.done += 1
        if not self.enabled:
            return
        width = 24
        filled = int(width * self.done / max(self.total, 1))
        bar = "#" * filled + "." * (width - filled)
        text = f"[{bar}] {self.done}/{self.total} {outcome.name}: {outcome.status} ({outcome.seconds:.1f} s)"
        if self.tty:
            self.stream.write("\r\033[K" + text + ("\n" if self.done == self.total else ""))
        else:
            self.stream.write(text + "\n")
        self.stream.flush()


# ---------------------------------------------------------------------- batch
def report(paths: Sequence[str | os.PathLike[str]], out_dir: str | os.PathLike[str] = "plots", *,
           jobs: int = 1, force: bool = False, window_size: Sequence[int] | None = None,
           progress: bool = True) -> BatchResult:
    """Render every scene in `paths` (files or folders of ``*.toml``) into `out_dir`.

    Parameters
    ----------
    paths : sequence of path-like
        Scene files or folders.
    out_dir : path-like
        Output folder (created); gets the images, ``summary.json`` and ``index.html``.
    jobs : int
        Worker processes (1: run in this process).
    force : bool
        Redo scenes whose inputs are unchanged since their last successful run.
    window_size : (int, int), optional
        Override every scene's image size in pixels.
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    BatchResult

    Raises
    ------
    ValueError
        `jobs` < 1 or `paths` empty.
    """
    from vibra.scene import find_scene_files

    if isinstance(jobs, bool) or not isinstance(jobs, int):
        raise TypeError(f"jobs must be an int, got {type(jobs).__name__}")
    if jobs < 1:
        raise ValueError(f"jobs is {jobs}; expected jobs >= 1")
    files = find_scene_files(list(paths))
    if not files:
        raise ValueError(f"paths holds no scene file (*.toml): {[str(p) for p in paths]}")
    target = Path(out_dir)
    target.mkdir(parents=True, exist_ok=True)
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
    if jobs == 1 or len(pending) <= 1:
        for i in pending:
            outcomes[i] = run_scene(files[i], target, force=force, window_size=size)
            bar.update(outcomes[i])  # type: ignore[arg-type]
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # spawn: a fresh interpreter per worker (VTK and forked GL state do not mix).
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(jobs, len(pending)), mp_context=context) as pool:
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
    result = BatchResult(out_dir=target, outcomes=tuple(o for o in outcomes if o is not None),
                         seconds=time.perf_counter() - start, jobs=jobs)
    try:
        (target / _WORK).rmdir()  # every scene is done; removed only when empty
    except OSError:
        pass
    write_summary(result)
    write_index(result)
    return result


def _claim_names(files: Sequence[Path]) -> list[str | None]:
    """An error for every file whose scene name repeats an earlier one (None otherwise).

    The name is read cheaply (a valid scene's ``name`` key or its file stem); two scenes
    with one name would write the same output files.
    """
    from vibra.scene import tomllib

    seen: dict[str, Path] = {}
    errors: list[str | None] = []
    for file in files:
        name = file.stem
        try:
            data = tomllib.loads(file.read_text(encoding="utf-8"))
            if isinstance(data.get("name"), str):
                name = data["name"]
        except (OSError, ValueError):
            pass
        if name in seen:
            errors.append(f"{file}: name: scene name {name!r} is already used by {seen[name]}; "
                          "outputs would overwrite each other")
        else:
            seen[name] = file
            errors.append(None)
    return errors


def write_summary(result: BatchResult) -> Path:
    """Write ``summary.json`` (every scene: status, outputs, steps, errors), atomically."""
    payload = {
        "seconds": result.seconds, "jobs": result.jobs,
        "n_scenes": len(result.outcomes), "n_failed": len(result.failed),
        "scenes": [o.as_json() for o in result.outcomes],
    }
    return atomic_write_text(result.out_dir / "summary.json", json.dumps(payload, indent=1))


def write_index(result: BatchResult) -> Path:
    """Write ``index.html``: every image with its caption, the step table and the errors."""
    e = html.escape
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
             "<title>vibra report</title><style>",
             "body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}"
             "figure{margin:1em 0}img{max-width:100%;border:1px solid #ccc}"
             "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}"
             ".failed{color:#a00}pre{background:#f6f6f6;padding:.5em;overflow-x:auto}",
             "</style></head><body>", "<h1>vibra report</h1>",
             f"<p>{len(result.outcomes)} scene(s), {len(result.failed)} failed.</p>"]
    for o in result.outcomes:
        parts.append(f"<section id='{e(o.name, quote=True)}'><h2>{e(o.title)}</h2>")
        parts.append(f"<p>Scene file <code>{e(o.source)}</code>: <b class='{e(o.status)}'>{e(o.status)}</b>"
                     f" in {o.seconds:.2f} s.</p>")
        if o.error:
            parts.append(f"<pre class='failed'>{e(o.error)}</pre>")
        if o.steps:
            parts.append("<table><tr><th>step</th><th>what</th><th>solver</th><th>accuracy</th>"
                         "<th>time (s)</th></tr>")
            for s in o.steps:
                parts.append(f"<tr><td>{e(s.name)}</td><td>{e(s.what)}</td><td>{e(s.solver or '')}</td>"
                             f"<td>{e(s.accuracy or '')}</td><td>{s.seconds:.3f}</td></tr>")
            parts.append("</table>")
        for output, caption in zip(o.outputs, o.captions):
            link = e(output, quote=True)
            if output.endswith((".png", ".gif")):
                parts.append(f"<figure><img src='{link}' alt='{e(caption, quote=True)}'>"
                             f"<figcaption>{e(caption)}</figcaption></figure>")
            else:
                parts.append(f"<p><a href='{link}'>{e(output)}</a>: {e(caption)}</p>")
        if o.frequencies:
            parts.append("<details><summary>frequencies</summary><pre>"
                         + e("\n".join(o.frequencies)) + "</pre></details>")
        parts.append("</section>")
    parts.append("</body></html>")
    return atomic_write_text(result.out_dir / "index.html", "\n".join(parts) + "\n")
