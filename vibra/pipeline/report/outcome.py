"""What `vibra report` returns and stores: `SceneOutcome`, `BatchResult`, and the `ProgressBar`."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from vibra._core.text import counted
__all__ = ["SceneOutcome", "BatchResult", "ProgressBar"]


def _finite_or_none(values: Any) -> list[float | None]:
    return [float(v) if math.isfinite(v) else None for v in values]


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
        Why it failed, one line ("" otherwise).
    outputs : tuple of str
        Files written, relative to the output folder.
    captions : tuple of str
        One caption per output.
    steps : tuple of StepRecord
        `vibra.pipeline.plan.StepRecord` per executed step.
    frequencies : tuple of str
        Lines of the frequency table (text, for the terminal and the index).
    seconds : float
        Wall time of the scene, in s.
    input_hash : str
        The skip key: SHA-256 of the scene file, vibra's version, a hash of vibra's code and
        the options.
    omega : tuple of float
        The modes' angular frequencies, in `omega_unit`.
    omega_unit : str
        Unit of `omega` (``"rad/s"`` for SI scenes).
    frequency : tuple of float
        The same modes in a spectroscopic unit (Hz for chains, cm^-1 for molecules; empty
        for dimensionless scenes).
    frequency_unit : str
        Unit of `frequency`.
    detail : str
        The traceback of an unexpected failure ("" otherwise), shown with ``--debug``.
    kind : str
        The scene's kind (``"chain"``, ``"molecule"``, ...; "" when the file could not be read).
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
    omega: tuple[float, ...] = ()
    omega_unit: str = ""
    frequency: tuple[float, ...] = ()
    frequency_unit: str = ""
    detail: str = ""
    kind: str = ""

    def as_json(self) -> dict[str, Any]:
        """JSON-ready description (used in ``summary.json`` and the manifests); numbers stay numbers.

        ``frequencies`` holds ``omega`` (floats, non-finite as null) with ``omega_unit`` and the
        spectroscopic ``values`` with their ``unit``; the text table is ``frequency_table``.
        """
        return {
            "source": self.source, "name": self.name, "title": self.title, "kind": self.kind,
            "status": self.status,
            "error": self.error, "outputs": list(self.outputs), "captions": list(self.captions),
            "steps": [{"name": s.name, "what": s.what, "seconds": s.seconds, "solver": s.solver,
                       "accuracy": s.accuracy, "outputs": list(s.outputs)} for s in self.steps],
            "frequencies": {"omega": _finite_or_none(self.omega), "omega_unit": self.omega_unit,
                            "values": _finite_or_none(self.frequency), "unit": self.frequency_unit},
            "frequency_table": list(self.frequencies), "seconds": self.seconds,
            "input_hash": self.input_hash, "traceback": self.detail,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SceneOutcome:
        """Rebuild an outcome stored by `as_json` (steps come back as `StepRecord`)."""
        from vibra.pipeline.plan import StepRecord

        steps = tuple(StepRecord(name=s["name"], what=s["what"], seconds=float(s["seconds"]),
                                 solver=s.get("solver"), accuracy=s.get("accuracy"),
                                 outputs=tuple(s.get("outputs", ()))) for s in data.get("steps", ()))
        numbers = data.get("frequencies", {})
        numbers = numbers if isinstance(numbers, dict) else {}

        def floats(values: Any) -> tuple[float, ...]:
            return tuple(float("nan") if v is None else float(v) for v in values or ())

        return cls(source=str(data["source"]), name=str(data["name"]), title=str(data["title"]),
                   status=str(data["status"]), error=str(data.get("error", "")),
                   outputs=tuple(str(o) for o in data.get("outputs", ())),
                   captions=tuple(str(c) for c in data.get("captions", ())), steps=steps,
                   frequencies=tuple(data.get("frequency_table", ())), seconds=float(data.get("seconds", 0.0)),
                   input_hash=str(data.get("input_hash", "")), omega=floats(numbers.get("omega")),
                   omega_unit=str(numbers.get("omega_unit", "")), frequency=floats(numbers.get("values")),
                   frequency_unit=str(numbers.get("unit", "")), detail=str(data.get("traceback", "")),
                   kind=str(data.get("kind", "")))


@dataclass(frozen=True)
class BatchResult:
    """The outcome of `report`.

    Attributes
    ----------
    out_dir : Path
        The output folder.
    outcomes : tuple of SceneOutcome
        One per scene file of this run, in the order given.
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
        lines.append(f"{counted(len(self.outcomes), 'scene')}, {len(self.failed)} failed, "
                     f"{counted(self.n_images, 'image')}, {self.seconds:.1f} s with {counted(self.jobs, 'job')}")
        return "\n".join(lines)


class ProgressBar:
    """A small text progress bar on a stream (stderr by default); a line per scene off a tty."""

    def __init__(self, total: int, *, stream: TextIO | None = None, enabled: bool = True) -> None:
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


