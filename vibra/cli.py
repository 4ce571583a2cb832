"""The ``vibra`` command: ``report``, ``validate`` and ``modes``.

Only argparse and pathlib are imported at start-up, so ``vibra --help`` answers fast;
numpy, scipy, pyvista and the analyses load inside the command that needs them.

Exit codes: 0 success; 1 one or more scenes failed (invalid or failing); 2 usage error;
130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

__all__ = ["main", "build_parser"]


def _window(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"window size must look like 800x600, got {text!r}") from None
    if not (64 <= width <= 4096 and 64 <= height <= 4096):
        raise argparse.ArgumentTypeError(f"window size {text!r} out of range (64..4096 pixels per side)")
    return width, height


def _jobs(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--jobs must be an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"--jobs must be >= 1, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``vibra`` command."""
    parser = argparse.ArgumentParser(
        prog="vibra", description="Normal-mode and vibration analysis: render scene files to PNG reports.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    rep = sub.add_parser("report", help="render scene files (or folders of *.toml) to PNG, summary.json, index.html")
    rep.add_argument("paths", nargs="+", metavar="PATH", help="scene files or folders")
    rep.add_argument("--out", default="plots", metavar="DIR", help="output folder (default: plots/)")
    rep.add_argument("--jobs", "-j", type=_jobs, default=1, metavar="N", help="parallel worker processes")
    rep.add_argument("--force", action="store_true", help="redo scenes whose inputs did not change")
    rep.add_argument("--window-size", type=_window, default=None, metavar="WxH",
                     help="override the image size of every scene, e.g. 800x500")
    rep.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    val = sub.add_parser("validate", help="check scene files against the schema and build their systems (no solve)")
    val.add_argument("paths", nargs="+", metavar="PATH", help="scene files or folders")
    mod = sub.add_parser("modes", help="print a table of a scene's frequencies")
    mod.add_argument("scene", metavar="SCENE", help="one scene file")
    return parser


def _validate(paths: Sequence[str]) -> int:
    from vibra.plan import build_system
    from vibra.scene import SceneError, find_scene_files, load_scene

    files = find_scene_files(list(paths))
    if not files:
        print(f"vibra validate: no scene file (*.toml) in {list(paths)}", file=sys.stderr)
        return 1
    failed = 0
    for file in files:
        try:
            scene = load_scene(file)
            build_system(scene)  # the builders' own checks: what validates also builds
        except SceneError as error:
            failed += 1
            print(f"FAIL {error}")
        else:
            print(f"ok   {file} ({scene.kind}, builder {scene.system.builder!r})")
    print(f"{len(files)} scene(s), {failed} invalid")
    return 1 if failed else 0


def _modes(path: str) -> int:
    import time

    from vibra.plan import build_system, frequency_lines
    from vibra.scene import SceneError, load_scene

    try:
        scene = load_scene(path)
    except SceneError as error:
        print(f"vibra modes: {error}", file=sys.stderr)
        return 1
    if scene.kind == "oscillator":
        print(f"vibra modes: {path}: an oscillator scene has no normal modes to list", file=sys.stderr)
        return 1
    start = time.perf_counter()
    try:
        system = build_system(scene)
        compute = scene.compute
        modes = system.modes(compute.n_modes, accuracy=compute.accuracy, vectors=False, band=compute.band,
                             solver=compute.solver)
    except Exception as error:
        print(f"vibra modes: {path}: {type(error).__name__}: {error}", file=sys.stderr)
        return 1
    seconds = time.perf_counter() - start
    print(f"{scene.title}: {modes.n_modes} of {system.n_dof} modes, solver {modes.solver}, {seconds:.3f} s")
    print("\n".join(frequency_lines(scene, modes)))
    return 0


def _report(args: argparse.Namespace) -> int:
    from vibra.report import report

    try:
        result = report(args.paths, Path(args.out), jobs=args.jobs, force=args.force,
                        window_size=args.window_size, progress=not args.quiet)
    except ValueError as error:
        print(f"vibra report: {error}", file=sys.stderr)
        return 1
    print(result.table())
    for outcome in result.failed:
        print(f"\nFAILED {outcome.name}:\n{outcome.error}", file=sys.stderr)
    print(f"open {Path(args.out) / 'index.html'}")
    return 1 if result.failed else 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``vibra`` command with `argv` (default: the process arguments); return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        if args.command == "validate":
            return _validate(args.paths)
        if args.command == "modes":
            return _modes(args.scene)
        return _report(args)
    except KeyboardInterrupt:
        print("\nvibra: interrupted; finished images are complete, unfinished scenes left no output",
              file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a reader that stopped (`vibra validate ... | head`)
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 1


if __name__ == "__main__":
    sys.exit(main())
