"""The one atomic file writer of vibra: every file vibra writes goes through `atomic_write`.

A file is written to a temporary name in its destination folder (hidden, with the writer's pid:
``.<name>.<pid>~tmp~<random>``, see `temporary_owner`) (so the final rename never
crosses file systems), given the mode an ordinary ``open()`` would give it (0666 less the
user's umask: 0644 under umask 022), then renamed over the target with `os.replace`. A reader
therefore sees the old file or the complete new one, never half of one; on any exception
(KeyboardInterrupt included) the temporary file is removed and the target is left as it was.

>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> atomic_write_text(folder / "a.txt", "hello").read_text()
'hello'
>>> atomic_write_bytes(folder / "b.bin", b"\\x00\\x01").read_bytes()
b'\\x00\\x01'
>>> sorted(p.name for p in folder.iterdir())
['a.txt', 'b.bin']
"""

from __future__ import annotations

import os
import tempfile
import threading
from pathlib import Path
from typing import Callable

__all__ = ["atomic_write", "atomic_write_text", "atomic_write_bytes", "file_mode", "TEMPORARY_MARK",
           "temporary_owner"]

#: Between the writer's pid and mkstemp's random letters in a temporary name:
#: ``.<target name>.<pid>~tmp~<random><suffix>``, so a temporary file left by a killed process
#: can be told from one being written (`temporary_owner`).
TEMPORARY_MARK = "~tmp~"

_UMASK_LOCK = threading.Lock()


def file_mode() -> int:
    """Permission bits of a new file: 0o666 less the process umask (0o644 under umask 022)."""
    try:  # Linux: read the umask without changing it (thread-safe)
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    with _UMASK_LOCK:  # elsewhere: set and restore it at once
        mask = os.umask(0o022)
        os.umask(mask)
    return 0o666 & ~mask


def temporary_owner(name: str) -> int | None:
    """The pid that created the temporary file called `name` (None when `name` is not one of ours)."""
    if not name.startswith(".") or TEMPORARY_MARK not in name:
        return None
    head = name.rsplit(TEMPORARY_MARK, 1)[0]
    pid = head.rsplit(".", 1)[-1]
    return int(pid) if pid.isdigit() else None


def atomic_write(path: str | os.PathLike[str], write: Callable[[Path], object], *,
                 suffix: str = ".tmp") -> Path:
    """Create `path` atomically: `write(temporary_path)` fills a temporary file, then it is renamed.

    Parameters
    ----------
    path : path-like
        The file to create or replace; its folder is created when missing.
    write : callable
        Called once with the temporary file's path (an empty file in the same folder); it
        writes the content there (``figure.savefig(p)``, ``image.save(p)``, ...).
    suffix : str
        Ending of the temporary name (some writers pick a format from it).

    Returns
    -------
    Path
        `path`, now holding the complete file with mode 0666 less the umask.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}{TEMPORARY_MARK}", suffix=suffix,
                                    dir=target.parent)
    os.close(handle)
    temporary = Path(name)
    try:
        write(temporary)
        os.chmod(temporary, file_mode())  # mkstemp creates 0600 files
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return target


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write `data` to `path` atomically (see `atomic_write`)."""
    return atomic_write(path, lambda temporary: temporary.write_bytes(data))


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write `text` (UTF-8) to `path` atomically (see `atomic_write`)."""
    return atomic_write_bytes(path, text.encode("utf-8"))
