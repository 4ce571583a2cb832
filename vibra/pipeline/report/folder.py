"""The output folder of `vibra report`: checked, locked, cleaned, and its files verified before reuse.

- `check_out_dir`: the folder must be a folder (created when missing) that vibra can write,
  outside the system folders, and new, empty or vibra's own output (``.vibra/``) unless
  ``force`` (`vibra._core.filesystem.check_out_folder`, `vibra._core.filesystem.claim_out_folder`); a regular file, a
  dangling symlink, a symlink loop, a device (``/dev/null``), a read-only folder, ``/``,
  ``/etc`` or a folder of someone else's files (a symlink to one included) is refused with
  one line, before anything is written.
- `FolderLock`: one `vibra report` at a time per folder. The lock is ``DIR/.vibra/lock``, an
  ``fcntl.flock`` on an open file (released by the kernel when its holder dies, so a killed
  run never leaves the folder locked) holding the holder's pid, start time and command. A
  second run waits up to its ``wait`` seconds (``--wait``, default 60) for the lock, then
  refuses with `FolderBusy`, naming the holder.
- `clean_stale`: removes the work folders (``DIR/.work/<pid>/``) and temporary files
  (``.<name>.<pid>~tmp~...``, `vibra._core.filesystem`) of processes that no longer run.
- `output_is_sound`: a stored PNG or GIF must decode, a JSON must parse, no file may be empty;
  a scene whose stored outputs fail this is run again instead of skipped.
- `code_hash`: SHA-256 of vibra's own ``.py`` files, part of the skip key (changed code
  never serves stale images).
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import shutil
import stat
import sys
import time
from pathlib import Path
from types import TracebackType
from typing import Iterable

from vibra._core.cache import source_hash
from vibra._core.filesystem import (
    OWN_MARK, TargetRefused, atomic_write_text, check_out_folder, check_target, claim_out_folder, describe_kind,
    pid_alive, temporary_owner,
)

__all__ = ["MANIFESTS", "WORK", "LOCK_NAME", "PAGE_FOLDERS", "FolderBusy", "FolderLock", "check_out_dir", "pid_alive",
           "clean_stale", "output_is_sound", "code_hash", "work_folder"]

MANIFESTS = OWN_MARK  # ".vibra": the skip records and the lock, and the mark of vibra's own folder
WORK = ".work"
LOCK_NAME = "lock"
#: Files `report` itself writes in the output folder (checked to be files, not folders).
FOLDER_FILES = ("summary.json", "index.html", "references.html")
#: Folders of the report's pages: the scene pages and the vendored scripts (checked to be folders).
PAGE_FOLDERS = ("scenes", "assets")


class FolderBusy(RuntimeError):
    """Another `vibra report` holds the output folder's lock (the message names it)."""


def check_out_dir(path: str | os.PathLike[str], *, inputs: Iterable[str | os.PathLike[str]] = (),
                  force: bool = False) -> Path:
    """Create the output folder when missing and check it is a writable folder report may fill; return it.

    The folder rule is `vibra._core.filesystem.check_out_folder`; then the names report writes itself
    (``summary.json``, ``index.html``, ``references.html``, ``scenes/``, ``assets/``, ``.vibra/``,
    ``.work/``) must be of the right kind and never a symbolic link, its own files never one of
    `inputs` (the scene files), and the folder new, empty or vibra's own unless `force`
    (`vibra._core.filesystem.claim_out_folder`, which marks it).

    Raises
    ------
    vibra._core.filesystem.TargetRefused
        `path` (or a parent) is a file, device, dangling symlink or symlink loop; the folder
        (or the parent it would be made in) is not writable or a system folder; a report file
        would replace an input; the folder holds files vibra did not write (without `force`).
    NotADirectoryError
        One of report's own names is a folder where a file goes, or the reverse.
    """
    target = check_out_folder(path, option="--out")
    for name in (MANIFESTS, WORK, *PAGE_FOLDERS, *FOLDER_FILES):
        entry = target / name
        wanted_dir = name not in FOLDER_FILES
        if os.path.lexists(entry) and (entry.is_dir() != wanted_dir or entry.is_symlink()):
            role = "report pages" if name in PAGE_FOLDERS else "bookkeeping" if wanted_dir else "report"
            what = (f"a symbolic link (to {os.readlink(entry)}), not a {'folder' if wanted_dir else 'file'}; vibra "
                    "follows no link out of its output folder" if entry.is_symlink()
                    else "not a folder" if wanted_dir else "a folder")
            raise NotADirectoryError(f"--out {target}: {entry} is {what}; vibra writes its {role} there; "
                                     "remove or rename it")
    for name in (MANIFESTS, *PAGE_FOLDERS):  # report's own folders hold its regular files only
        try:
            entries = list(os.scandir(target / name))
        except FileNotFoundError:
            continue
        for entry in entries:
            kind = os.lstat(entry.path).st_mode
            if not stat.S_ISREG(kind):
                what = f"a symbolic link (to {os.readlink(entry.path)})" if stat.S_ISLNK(kind) else describe_kind(kind)
                raise TargetRefused(entry.path, f"is {what}; vibra keeps only its own regular files in {name}/ and "
                                    "follows no link out of its output folder; remove it", option="--out")
    for name in FOLDER_FILES:  # before any work: report's own files never replace a scene file
        check_target(target / name, option="--out", inputs=inputs)
    return claim_out_folder(target, option="--out", force=force)


def work_folder(out_dir: Path) -> Path:
    """This process's work folder, ``DIR/.work/<pid>/`` (scenes stage their files below it)."""
    return out_dir / WORK / str(os.getpid())


def clean_stale(out_dir: Path) -> list[Path]:
    """Remove work folders and temporary files of processes that no longer run; return what went.

    Work folders are ``DIR/.work/<pid>/``; temporary files are `vibra._core.filesystem`'s
    ``.<name>.<pid>~tmp~...`` in ``DIR`` and ``DIR/.vibra``. Those of a live process stay.
    """
    removed: list[Path] = []
    work = out_dir / WORK
    if work.is_dir():
        for entry in work.iterdir():
            owner = entry.name.split("-")[-1]  # "<pid>" (and the "<scene>-<pid>" of older versions)
            if entry.is_symlink() or not owner.isdigit() or not pid_alive(int(owner)):  # a link is never ours
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry, ignore_errors=True)
                else:
                    entry.unlink(missing_ok=True)
                removed.append(entry)
    for folder in (out_dir, out_dir / MANIFESTS):
        if not folder.is_dir():
            continue
        for entry in folder.iterdir():
            writer = temporary_owner(entry.name)
            if writer is not None and not pid_alive(writer) and entry.is_file():
                entry.unlink(missing_ok=True)
                removed.append(entry)
    return removed


def output_is_sound(path: Path) -> bool:
    """True when `path` is a non-empty regular file (not a link) that decodes (PNG/GIF) or parses (JSON)."""
    try:
        info = os.lstat(path)
    except OSError:
        return False
    if not stat.S_ISREG(info.st_mode) or info.st_size == 0:
        return False
    suffix = path.suffix.lower()
    try:
        if suffix in (".png", ".gif"):
            from PIL import Image  # Pillow comes with matplotlib

            with Image.open(path) as image:
                image.load()  # a truncated file raises here
                frames = int(getattr(image, "n_frames", 1))
                if frames > 1:  # an animation: its last frame must decode too
                    image.seek(frames - 1)
                    image.load()
        elif suffix == ".json":
            json.loads(path.read_text(encoding="utf-8"))
        elif suffix in (".txt", ".html"):
            path.read_text(encoding="utf-8")
    except Exception:  # any decoder failure means: not trusted, redo the scene
        return False
    return True


def code_hash() -> str:
    """SHA-256 of the bytes of every ``.py`` file of the vibra package (computed once per process):
    `vibra._core.cache.source_hash`, the key of the derived values' cache too."""
    return source_hash()


class FolderLock:
    """The lock of one output folder, held for a whole `report` run (a context manager).

    Parameters
    ----------
    out_dir : Path
        The output folder (checked by `check_out_dir`).
    wait : float
        Seconds to wait for another run to finish before refusing (0: refuse at once), in s.
    poll : float
        Seconds between attempts, in s.
    """

    def __init__(self, out_dir: Path, *, wait: float = 60.0, poll: float = 0.2) -> None:
        self.path = out_dir / MANIFESTS / LOCK_NAME
        self.wait = wait
        self.poll = poll
        self.handle: int | None = None

    def holder(self) -> str:
        """Who holds the lock, in words, from the lock file."""
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
            started = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(float(data["started"])))
            return f"pid {int(data['pid'])}, started {started}, command {data.get('command', '?')!r}"
        except (OSError, ValueError, KeyError, TypeError):
            return "another vibra report (its details are not written yet)"

    def acquire(self) -> None:
        """Take the lock, waiting up to `wait` seconds; raise `FolderBusy` naming the holder."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:  # never through a link, nor a FIFO or a file linked elsewhere: the lock is truncated in place
            descriptor = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK, 0o666)
        except OSError as error:
            if error.errno != errno.ELOOP:
                raise
            raise TargetRefused(self.path, "is a symbolic link; vibra follows no link out of its output folder; "
                                "remove it", option="--out") from None
        info = os.fstat(descriptor)
        if not stat.S_ISREG(info.st_mode) or info.st_nlink != 1:
            os.close(descriptor)
            what = describe_kind(info.st_mode) if not stat.S_ISREG(info.st_mode) else \
                f"a file with {info.st_nlink} names (a hard link)"
            raise TargetRefused(self.path, f"is {what}; vibra keeps its own lock file there; remove it",
                                option="--out")
        deadline = time.monotonic() + self.wait
        while True:
            try:
                fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    holder = self.holder()
                    os.close(descriptor)
                    waited = f"after waiting {self.wait:g} s" if self.wait > 0 else "(--wait 0)"
                    raise FolderBusy(f"--out {self.path.parent.parent}: in use by {holder} {waited}; wait for it "
                                     "to finish, use another --out, or give --wait SECONDS") from None
                time.sleep(self.poll)
        self.handle = descriptor
        info = {"pid": os.getpid(), "started": time.time(), "command": " ".join(sys.argv)}
        os.ftruncate(descriptor, 0)
        os.pwrite(descriptor, json.dumps(info).encode(), 0)

    def release(self) -> None:
        """Release the lock (the file stays; its content is cleared)."""
        if self.handle is not None:
            try:
                os.ftruncate(self.handle, 0)
                fcntl.flock(self.handle, fcntl.LOCK_UN)
            finally:
                os.close(self.handle)
                self.handle = None

    def __enter__(self) -> FolderLock:
        self.acquire()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.release()


def write_manifest(out_dir: Path, name: str, text: str) -> Path:
    """Write a scene's manifest ``DIR/.vibra/<name>.json`` (atomically)."""
    return atomic_write_text(out_dir / MANIFESTS / f"{name}.json", text)
