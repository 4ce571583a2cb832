"""The ``vibra`` command: ``report``, ``validate``, ``modes`` and ``sweep``.

Only argparse and pathlib are imported at start-up, so ``vibra --help`` answers fast;
numpy, scipy, pyvista and the analyses load inside the command that needs them.

Every failure is one line on stderr (``file: key.path: what is wrong; what is expected``)
and a non-zero exit, never a traceback; an unexpected exception is reported in one line too,
with a hint to rerun with ``--debug``, which shows the traceback.

What each command may replace (one rule for every file, `vibra._core.filesystem.check_target`: a target is
a regular file or a new name, never a folder, device, FIFO, socket or symbolic link, and never
one of the run's inputs, the scene file or the .xyz / .pdb file it names):

- ``vibra report --out DIR``: its own files in DIR (``<scene>_*.png``/``.gif``/``.txt``,
  ``summary.json``, ``index.html``, ``.vibra/``), rewritten on every run;
- ``vibra sweep --out DIR``: ``<scene>_sweep.csv``, ``.json`` and ``.png`` in DIR, rewritten on
  every run (all three are checked before any is written);
- ``vibra modes --molden FILE``: a new FILE only; an existing one is replaced with ``--force``.

Every ``--out DIR`` is new, empty or a folder vibra wrote before (marked by ``DIR/.vibra/``), unless
``--force``, and never ``/`` nor a system folder (``/etc``, ``/usr``, ... `vibra._core.filesystem.check_out_folder`,
`vibra._core.filesystem.claim_out_folder`).

Exit codes: 0 success; 1 one or more scenes failed (invalid or failing), or the output folder
is busy or unusable; 2 usage error (a bad option, a scene path that does not exist: nothing
is written); 3 an unexpected internal error; 130 interrupted (Ctrl-C); 143 (129) terminated by
SIGTERM (SIGHUP), which, like Ctrl-C, removes the run's work folders before exiting.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from pathlib import Path
from typing import Any, Callable, Iterator, NoReturn, Sequence

from vibra._core.text import counted

__all__ = ["main", "build_parser", "EXIT_OK", "EXIT_FAILED", "EXIT_USAGE", "EXIT_INTERNAL"]

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 130

#: A sweep of more points than this first prints its size and an estimate of its time (one line on
#: stderr, --quiet or not): 10^5 points once ran ~12 minutes without a word.
ANNOUNCE_POINTS = 1000


class _Parser(argparse.ArgumentParser):
    """argparse, with usage errors in one line: ``vibra report: error: ...; see vibra report --help``."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}; see {self.prog} --help\n")


def _window(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"window size must look like 800x600, got {text!r}") from None
    if not (64 <= width <= 4096 and 64 <= height <= 4096):
        raise argparse.ArgumentTypeError(f"window size {text!r} out of range (64..4096 pixels per side)")
    return width, height


def _positive_int(option: str) -> Callable[[str], int]:
    """An argparse type: an integer >= 1, refused in one line naming `option`."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} must be an integer, got {text!r}") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{option} must be >= 1, got {value}")
        return value
    return parse


def _seconds(option: str, high: float, *, zero: bool) -> Callable[[str], float]:
    """An argparse type: seconds up to `high` (0 itself only with `zero`), refused in one line naming `option`."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} must be a number of seconds, got {text!r}") from None
        if not ((value >= 0 if zero else value > 0) and value <= high):
            raise argparse.ArgumentTypeError(f"{option} must be between 0 and {high:g} s, got {text}")
        return value
    return parse


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vibra")
    except PackageNotFoundError:  # run from a source tree that is not installed
        return "unknown"


class _VersionAction(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata costs 25 ms)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="show the program's version number and exit")

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        print(f"vibra {_version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``vibra`` command."""
    parser = _Parser(
        prog="vibra", description="Normal-mode and vibration analysis: render scene files to PNG reports.")
    parser.add_argument("--version", action=_VersionAction)
    parser.add_argument("--debug", action="store_true", help="show the traceback of an unexpected error")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    rep = sub.add_parser("report", help="render scene files (or folders of *.toml) to PNG, summary.json, index.html")
    rep.add_argument("paths", nargs="+", metavar="PATH", help="scene files or folders (each must exist)")
    rep.add_argument("--out", default="plots", metavar="DIR",
                     help="output folder (default: plots/): new, empty, or one vibra wrote before (else --force); "
                          "each run rewrites its own files there (<scene>_*.png, summary.json, index.html), never an "
                          "input nor anything but a regular file")
    rep.add_argument("--jobs", "-j", type=_positive_int("--jobs"), default=None, metavar="N",
                     help="parallel worker processes (default: the cores this process may use)")
    rep.add_argument("--force", action="store_true", help="redo scenes whose inputs did not change, and write into "
                     "an existing --out folder that vibra did not write (never a system folder)")
    rep.add_argument("--window-size", type=_window, default=None, metavar="WxH",
                     help="override the image size of every scene, e.g. 800x500")
    rep.add_argument("--wait", type=_seconds("--wait", 86400, zero=True), default=60.0, metavar="SECONDS",
                     help="how long to wait for another report writing into the same folder (default 60; "
                          "0: refuse at once)")
    rep.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    _add_scheduler(rep, "scenes")
    val = sub.add_parser("validate", help="check scene files and build their systems: every check the report runs "
                         "before solving; prints each scene's size and estimated cost, or every problem of its "
                         "keys (a FAIL line each)")
    val.add_argument("paths", nargs="+", metavar="PATH", help="scene files or folders")
    mod = sub.add_parser("modes", help="print a table of a scene's frequencies")
    mod.add_argument("scene", metavar="SCENE", help="one scene file")
    mod.add_argument("--molden", metavar="FILE", help="also write the vibrations of a molecule scene as a Molden "
                     "normal-mode file (Avogadro, Jmol, Molden); FILE must be new (or --force), a regular file, "
                     "and not one of the scene's inputs")
    mod.add_argument("--force", action="store_true", help="let --molden replace an existing regular file")
    swp = sub.add_parser("sweep", help="solve one scene over ranges of parameter values: a table (CSV, JSON) "
                         "and a chart")
    swp.add_argument("scene", metavar="SCENE", help="one scene file")
    swp.add_argument("--vary", action="append", required=True, metavar="KEY=START:STOP:N",
                     help="a dotted key of the scene and its range, e.g. system.defect_mass=0.2:0.8:7, one value "
                          "of a list, e.g. system.stiffness[1]=50:150:5, or a response key (compute.response.alpha: "
                          "the table gets the response's peak); KEY=log:START:STOP:N for logarithmic spacing; repeat "
                          "for a grid")
    swp.add_argument("--out", default="plots", metavar="DIR",
                     help="output folder (default: plots/): new, empty, or one vibra wrote before (else --force); "
                          "each run rewrites <scene>_sweep.csv, .json and .png there (regular files only, never an "
                          "input)")
    swp.add_argument("--force", action="store_true", help="write into an existing --out folder that vibra did not "
                     "write (never a system folder)")
    swp.add_argument("--max-points", type=_positive_int("--max-points"), default=None, metavar="N",
                     help="refuse grids of more than N points (default 100000); the refusal gives the count "
                          "and an estimate of the time from one solved point")
    swp.add_argument("--jobs", "-j", type=_positive_int("--jobs"), default=None, metavar="N",
                     help="worker processes of --scheduler local (default: the cores this process may use)")
    swp.add_argument("--chunk-size", type=_positive_int("--chunk-size"), default=1, metavar="N", help="points per Dask task (default 1)")
    swp.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    _add_scheduler(swp, "points")
    return parser


def _add_scheduler(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help=f"run the {what} on Dask: 'local' (a local cluster of --jobs processes) or a "
                             "scheduler address such as tcp://host:8786; needs vibra[distributed]")
    parser.add_argument("--timeout", type=_seconds("--timeout", 3600, zero=False), default=10.0, metavar="SECONDS",
                        help="how long to wait for the scheduler to answer (default 10)")


def _validate(paths: Sequence[str]) -> int:
    from vibra.pipeline.scene import SceneError, find_scene_files, load_scene

    files = find_scene_files(list(paths))
    if not files:
        print(f"vibra validate: {', '.join(paths)}: no scene file (*.toml) there; expected scene files or folders "
              "of them", file=sys.stderr)
        return EXIT_FAILED
    failed = 0
    for file in files:
        try:
            scene = load_scene(file)  # a scene refused here imports no plan (issue 45: ~0.4 s)
            from vibra.pipeline.plan import cost_summary, validate

            system = validate(scene)  # the builders' own checks, and what the later steps would refuse
        except SceneError as error:  # every problem of the scene's keys, one line each
            failed += 1
            for problem in error.errors:
                print(f"FAIL {problem}")
        else:
            cost = cost_summary(scene, system)
            print(f"ok   {file} ({scene.kind}, builder {scene.system.builder!r}): {cost}")
    print(f"{counted(len(files), 'scene')}, {failed} invalid")
    return EXIT_FAILED if failed else EXIT_OK


def _check_molden(scene: Any, target: str, force: bool) -> None:
    """`vibra modes --molden FILE`, before any work: a molecule scene, and FILE a new (or, with
    --force, an existing regular) file that is not one of the scene's inputs."""
    from vibra._core.filesystem import TargetRefused, check_target
    from vibra.pipeline.scene import SceneError, scene_inputs

    if scene.kind != "molecule":
        raise SceneError(scene.source, "kind", "--molden writes molecules only (a 3-D molecule scene); this is a "
                         f"{scene.kind!r} scene")
    try:
        check_target(target, option="--molden", inputs=scene_inputs(scene), replace=force, force_hint="--force")
    except TargetRefused as error:
        raise SceneError(scene.source, "", str(error)) from None


def _write_molden(scene: Any, system: Any, target: str) -> None:
    """`vibra modes --molden FILE`: the molecule's vibrations as a Molden file; refusals as a SceneError."""
    from vibra._core.filesystem import TargetRefused, protected_inputs
    from vibra.molecules import vibrational_analysis, write_molden
    from vibra.pipeline.scene import SceneError, scene_inputs

    if scene.kind != "molecule" or getattr(system, "dim", None) != 3:
        raise SceneError(scene.source, "kind", "--molden writes molecules only (a 3-D molecule scene); this is a "
                         f"{scene.kind!r} scene" + ("" if scene.kind != "molecule" else " in 1-D"))
    try:
        with protected_inputs(scene_inputs(scene)):
            write_molden(target, system, vibrational_analysis(system))
    except TargetRefused as error:
        error.option = "--molden"
        raise SceneError(scene.source, "", str(error)) from None
    except OSError as error:
        raise SceneError(scene.source, "", f"--molden: cannot write {target!r} "
                         f"({error.strerror or type(error).__name__})") from None
    except (ValueError, TypeError) as error:
        raise SceneError(scene.source, "", f"--molden: {error}") from None


def _modes(path: str, molden: str | None = None, force: bool = False) -> int:
    import time

    from vibra.pipeline.plan import REFUSALS, build_system, check_plan, frequency_lines, step_error
    from vibra.pipeline.plan.analysis import molecule_symmetry
    from vibra.pipeline.scene import SCENE_KINDS, SceneError, load_scene

    try:
        scene = load_scene(path)
        refusal = SCENE_KINDS[scene.kind].no_modes
        if refusal is not None:
            raise SceneError(path, "kind", refusal)
        if molden is not None:
            _check_molden(scene, molden, force)  # before any work: nothing is solved for a refused FILE
        start = time.perf_counter()
        compute = scene.compute
        try:
            system = build_system(scene)
            check_plan(scene, system, response=False)  # the table needs the modes only
            from vibra.pipeline.plan.electronic import engine_system

            system = engine_system(scene, system)  # an engine scene: the engine's Hessian (issue 46)
            modes = system.modes(compute.n_modes, accuracy=compute.accuracy, band=compute.band,
                                 vectors=scene.kind == "molecule",  # the species of a 1-D molecule need shapes
                                 solver=compute.solver)
        except REFUSALS as error:
            raise step_error(scene, "modes", error) from error
        if molden is not None:
            _write_molden(scene, system, molden)
    except SceneError as error:
        print(f"vibra modes: {error}", file=sys.stderr)
        return EXIT_FAILED
    seconds = time.perf_counter() - start
    symmetry = molecule_symmetry(system, modes) if scene.kind == "molecule" else None
    solver = getattr(modes, "solver", None) or getattr(modes, "method", "")  # QuadraticModes name a method
    print(f"{scene.title}: {modes.n_modes} of {counted(system.n_dof, 'mode')}, solver {solver}, {seconds:.3f} s")
    print("\n".join(frequency_lines(scene, modes, symmetry, ascii=not _unicode_output())))
    if molden is not None:
        print(f"Molden file written: {molden}")
    return EXIT_OK


def _unicode_output() -> bool:
    """Whether standard output can show ν, ⁻¹, √, γ and ∞ (else the table is written in ASCII)."""
    try:
        "ν⁻¹√γ∞".encode(sys.stdout.encoding or "ascii")
    except (UnicodeEncodeError, LookupError):
        return False
    return True


def _report(args: argparse.Namespace) -> int:
    from vibra._core.filesystem import TargetRefused
    from vibra.cluster import ClusterError
    from vibra.pipeline.report import FolderBusy, available_cores, missing_paths, report

    missing = missing_paths(args.paths)
    if missing:  # a typo: a usage error that touches nothing
        print(f"vibra report: {missing[0]}: no such file or folder; expected scene files (*.toml) or folders of "
              "them (nothing was written)", file=sys.stderr)
        return EXIT_USAGE
    try:
        result = report(args.paths, Path(args.out), jobs=args.jobs or available_cores(), force=args.force,
                        window_size=args.window_size, progress=not args.quiet, wait=args.wait,
                        scheduler=args.scheduler, timeout=args.timeout)
    except (ValueError, FolderBusy, ClusterError, ImportError, TargetRefused) as error:
        print(f"vibra report: {error}", file=sys.stderr)
        return EXIT_FAILED
    except OSError as error:  # the output folder refused (check_out_dir), or failed while writing
        text = str(error) if not error.strerror else (
            f"--out {args.out}: {error.strerror}" + (f" ({error.filename})" if error.filename else "")
            + "; expected a writable folder")
        print(f"vibra report: {text}", file=sys.stderr)
        return EXIT_FAILED
    print(result.table())
    for outcome in result.failed:
        for line in str(outcome.error).splitlines():  # a scene's problems, one line each (SceneError.errors)
            print(f"FAILED {line}", file=sys.stderr)
        if args.debug and outcome.detail:
            print(outcome.detail, file=sys.stderr)
    print(f"open {Path(args.out) / 'index.html'}")
    return EXIT_FAILED if result.failed else EXIT_OK


def _sweep(args: argparse.Namespace) -> int:
    from vibra._core.filesystem import TargetRefused, protected_inputs
    from vibra.charts import save_figure
    from vibra.charts.sweep import sweep_figure
    from vibra.cluster import ClusterError, check_client
    from vibra.pipeline.scene import SceneError, load_scene, scene_inputs
    from vibra.solvers.budget import describe_seconds
    from vibra.pipeline.sweep import DEFAULT_MAX_POINTS, estimate_seconds, grid, parse_vary, sweep

    try:
        points = grid(*(parse_vary(text) for text in args.vary))
        if args.scheduler is not None:
            check_client(args.scheduler, "--scheduler")
    except (ValueError, TypeError) as error:  # a usage error: nothing is read or written
        print(f"vibra sweep: {error}", file=sys.stderr)
        return EXIT_USAGE
    if not Path(args.scene).is_file():
        print(f"vibra sweep: {args.scene}: no such scene file; expected one scene file (*.toml) (nothing was written)",
              file=sys.stderr)
        return EXIT_USAGE
    try:
        scene = load_scene(args.scene)
        inputs = scene_inputs(scene)
        out = Path(args.out)
        _sweep_targets(out, scene.name, inputs, force=args.force, create=False)  # before the solve; made after it
        count, limit = len(points.points), args.max_points or DEFAULT_MAX_POINTS
        if ANNOUNCE_POINTS < count <= limit:  # a long sweep says so, once, even with --quiet
            estimate = estimate_seconds(args.scene, points)
            print(f"vibra sweep: {count:,} points; " + ("its time cannot be estimated before it runs" if estimate is None
                  else f"one point is estimated at ~{describe_seconds(estimate[0])} from its size ({estimate[1]}), "
                  f"so about {describe_seconds(count * estimate[0])} in one process"), file=sys.stderr)
        table = sweep(args.scene, points, client=args.scheduler, n_workers=args.jobs, timeout=args.timeout,
                      chunk_size=args.chunk_size, progress=not args.quiet,
                      max_points=args.max_points or DEFAULT_MAX_POINTS)
        targets = _sweep_targets(out, table.name, inputs, force=args.force, create=True)
        with protected_inputs(inputs):
            written = [table.to_csv(targets[0]), table.to_json(targets[1]),
                       save_figure(sweep_figure(table)[0], targets[2])]
    except SceneError as error:  # every problem of the scene, one line each
        for problem in error.errors:
            print(f"vibra sweep: {problem}", file=sys.stderr)
        return EXIT_FAILED
    except TargetRefused as error:
        print(f"vibra sweep: {error}", file=sys.stderr)
        return EXIT_FAILED
    except (ClusterError, ImportError, RuntimeError, ValueError, OSError) as error:
        print(f"vibra sweep: {args.scene}: {' '.join(str(error).split())}", file=sys.stderr)
        return EXIT_FAILED
    print(f"{table.name}: {counted(len(table.rows), 'point')} of {', '.join(table.keys)}, solver {table.rows[0].solver}")
    for path in written:
        print(f"wrote {path}")
    return EXIT_OK


def _sweep_targets(out: Path, name: str, inputs: Sequence[Any], *, force: bool, create: bool) -> list[Path]:
    """The files of ``vibra sweep --out``: the folder rule (`vibra._core.filesystem.check_out_folder`), then its three
    targets, all checked before any is written (never an input), then the ownership rule
    (`vibra._core.filesystem.claim_out_folder`, which marks the folder when `create`)."""
    from vibra._core.filesystem import check_out_folder, check_target, claim_out_folder

    check_out_folder(out, option="--out", create=create)
    targets = [out / f"{name}_sweep.{ending}" for ending in ("csv", "json", "png")]
    for target in targets:
        check_target(target, option="--out", inputs=inputs)
    claim_out_folder(out, option="--out", force=force, mark=create)
    return targets


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``vibra`` command with `argv` (default: the process arguments); return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return EXIT_USAGE
    import warnings

    def one_line(message: Warning | str, category: type[Warning], filename: str, lineno: int, file: Any = None,
                 line: str | None = None) -> None:  # a warning (a structure file that may be cut): one line
        print(f"vibra {args.command}: warning: {' '.join(str(message).split())}", file=sys.stderr)

    with warnings.catch_warnings(), _terminate_as_interrupt():
        warnings.showwarning = one_line
        return _dispatch(args)


class _Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where the program is, so that every ``finally`` runs: a report's
    work folders are removed and its finished images stay, as on Ctrl-C."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """Within this block (in the main thread), SIGTERM and SIGHUP raise `_Terminated`; the
    previous handlers come back after it."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum: int, frame: Any) -> None:
        raise _Terminated(signum)

    wanted = [getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)]
    previous = {signum: signal.signal(signum, terminate) for signum in wanted}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _dispatch(args: argparse.Namespace) -> int:
    """Run the chosen command; every failure becomes one line and an exit code."""
    try:
        if args.command == "validate":
            return _validate(args.paths)
        if args.command == "modes":
            return _modes(args.scene, args.molden, args.force)
        if args.command == "sweep":
            return _sweep(args)
        return _report(args)
    except _Terminated as stop:
        import signal

        print(f"\nvibra: terminated ({signal.Signals(stop.signum).name}); finished images are complete, "
              "unfinished scenes left no output", file=sys.stderr)
        return 128 + stop.signum
    except KeyboardInterrupt:
        print("\nvibra: interrupted; finished images are complete, unfinished scenes left no output",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # output piped into a reader that stopped (`vibra validate ... | head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return EXIT_FAILED
    except Exception as error:  # a bug: one line, the traceback only when asked for
        if args.debug:
            import traceback

            traceback.print_exc()
        text = " ".join(str(error).split())[:300]
        print(f"vibra {args.command}: internal error: {type(error).__name__}: {text}; rerun with --debug for "
              "the traceback and report it", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
