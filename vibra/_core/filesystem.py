"""The one atomic file writer of vibra: every file vibra writes goes through `atomic_write`.

**One rule for every target** (`check_target`, run by `atomic_write` before it writes and again
just before the rename): the target is a regular file or does not exist yet. A folder, a
device (``/dev/null``), a FIFO, a socket or a symbolic link is refused with `TargetRefused`
(an `OSError`) whose message is one line naming the path (and the option, for the command
line); so is any of the run's inputs (the scene file, its ``.xyz`` or ``.pdb`` file),
compared by resolved path and by inode (`os.path.samefile`: a hard link or a symlink to an
input is caught too). Inputs are given with ``inputs=`` or, for every writer called inside it,
with the context manager `protected_inputs` (the command line and the report use it). An
existing regular file is replaced unless ``replace=False`` (the command line's ``--molden``
without ``--force``). Nothing is opened, created or removed at a refused target.

**Never in a system folder** (`system_folder`): nothing is written in ``/`` itself, nor in
``/etc``, ``/usr``, ``/bin``, ``/proc``, ``/sys``, ``/dev`` ... or below them (`SYSTEM_TREES`,
`SYSTEM_TOPS`), compared by resolved path (a symlink to ``/etc`` is ``/etc``); ``force`` or
``--force`` never lifts this.

**One rule for every output folder** (`check_out_folder`, then `claim_out_folder`, for the
writers that fill a folder: ``vibra report``, ``vibra sweep``): the folder is created when
missing; an existing one must be a writable folder outside the system folders, and either
empty or vibra's own output, marked by a ``.vibra/`` folder (`OWN_MARK`) that vibra makes
there when it first writes in it. Any other folder (a home folder, a project, a symlink to
one) is refused unless ``force`` (``--force``). Inside it, vibra follows no symbolic link:
its own names (``.vibra``, ``.work``, pages) must be real folders and files.

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

import contextlib
import contextvars
import errno
import os
import stat
import tempfile
import threading
from pathlib import Path
from typing import Callable, Iterable, Iterator

__all__ = ["atomic_write", "atomic_write_text", "atomic_write_bytes", "file_mode", "TEMPORARY_MARK",
           "temporary_owner", "pid_alive", "remove_stale_temporaries", "TargetRefused", "check_target", "check_out_folder",
           "claim_out_folder", "protected_inputs", "describe_kind", "system_folder", "SYSTEM_TREES", "SYSTEM_TOPS",
           "OWN_MARK"]

#: Between the writer's pid and mkstemp's random letters in a temporary name:
#: ``.<target name>.<pid>~tmp~<random><suffix>``, so a temporary file left by a killed process
#: can be told from one being written (`temporary_owner`).
TEMPORARY_MARK = "~tmp~"

#: Folders vibra never writes in, nor anywhere below them (resolved paths).
SYSTEM_TREES = ("/bin", "/boot", "/dev", "/etc", "/lib", "/lib32", "/lib64", "/libx32", "/proc", "/run", "/sbin",
                "/sys", "/usr", "/var/lib", "/var/log", "/var/cache", "/var/spool", "/var/mail", "/snap", "/nix",
                "/System", "/Library", "/private/etc", "/private/var/db")

#: Folders vibra never writes in directly (their subfolders are the users' own: /home/ada, /var/tmp).
SYSTEM_TOPS = ("/", "/home", "/media", "/mnt", "/opt", "/srv", "/var", "/Users", "/Volumes", "/private",
               "/private/var")

#: The folder that marks an output folder as vibra's own (`claim_out_folder`); ``vibra report``
#: keeps its lock and skip records there.
OWN_MARK = ".vibra"

_UMASK_LOCK = threading.Lock()

#: The inputs of the run in progress (`protected_inputs`): every `atomic_write` refuses them.
_INPUTS: contextvars.ContextVar[tuple[Path, ...]] = contextvars.ContextVar("vibra_inputs", default=())


class TargetRefused(OSError):
    """A file vibra will not write: not a regular file, one of the run's inputs, or an existing
    file not to be replaced. ``str(error)`` is one line: ``[OPTION ]PATH: why; what is expected``.

    Attributes
    ----------
    path : str
        The refused target, as given.
    reason : str
        Why, and what is expected (without the path).
    option : str
        The command-line option that named the path (``"--molden"``), or ``""``.
    """

    def __init__(self, path: str | os.PathLike[str], reason: str, *, option: str = "",
                 code: int = errno.EINVAL) -> None:
        super().__init__(code, reason, str(path))
        self.path, self.reason, self.option = str(path), reason, option

    def __str__(self) -> str:
        return f"{self.option + ' ' if self.option else ''}{self.path}: {self.reason}"

    def __reduce__(self):  # type: ignore[no-untyped-def]  # picklable for Dask workers
        return (_refused, (self.path, self.reason, self.option, self.errno))


def _refused(path: str, reason: str, option: str, code: int) -> TargetRefused:
    return TargetRefused(path, reason, option=option, code=code)


def describe_kind(mode: int) -> str:
    """What a non-regular file is, in words (``"a folder"``, ``"a device"``, ...), from `os.stat`'s mode."""
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    return "not a regular file"


@contextlib.contextmanager
def protected_inputs(paths: Iterable[str | os.PathLike[str]]) -> Iterator[tuple[Path, ...]]:
    """Within this block, every `atomic_write` refuses the files `paths` (the run's inputs).

    Nested blocks add to the outer ones; missing paths are ignored (nothing to protect).
    """
    added = tuple(Path(p) for p in paths if p is not None and os.path.lexists(p))
    token = _INPUTS.set(_INPUTS.get() + added)
    try:
        yield _INPUTS.get()
    finally:
        _INPUTS.reset(token)


def _same_file(target: Path, source: Path) -> bool:
    """`target` is `source`: the same resolved path, or the same inode (hard link, symlink)."""
    try:
        if target.resolve() == source.resolve():
            return True
    except (OSError, RuntimeError):
        pass
    try:
        return os.path.samefile(target, source)
    except (OSError, ValueError):
        return False


def system_folder(path: str | os.PathLike[str]) -> str | None:
    """The system folder `path` is or lies in once resolved (`SYSTEM_TREES`: the folder or below;
    `SYSTEM_TOPS`: the folder itself), or None.

    >>> system_folder("/usr/share"), system_folder("/"), system_folder("/var"), system_folder("/var/tmp")
    ('/usr', '/', '/var', None)
    """
    real = os.path.realpath(path)
    for tree in SYSTEM_TREES:
        if real == tree or real.startswith(tree + os.sep):
            return tree
    return real if real in SYSTEM_TOPS else None


def _refuse_system(path: str | os.PathLike[str], folder: Path, option: str, verb: str) -> None:
    """Refuse `path` when `folder` (where it is written, or the folder itself: `verb` says which),
    or the existing folder in which `folder` would be created, is a system folder (`system_folder`)."""
    places = [(folder, verb)]
    existing = next((p for p in (folder, *folder.parents) if os.path.isdir(p)), None)
    if existing is not None and existing != folder:
        places.append((existing, "would be created in"))
    for place, said in places:
        system = system_folder(place)
        if system is not None:
            named = "the root folder /" if system == "/" else f"the system folder {system}"
            real = os.path.realpath(place)
            said = "is in" if said == "is" and real != system else said
            seen = "" if os.path.abspath(place) == real else f" ({place} resolves to {real})"
            raise TargetRefused(path, f"{said} {named}{seen}; vibra never writes in system folders, not even with "
                                "--force; expected a folder of your own", option=option, code=errno.EPERM)


def check_target(path: str | os.PathLike[str], *, option: str = "",
                 inputs: Iterable[str | os.PathLike[str]] = (), replace: bool = True,
                 force_hint: str = "replace=True") -> Path:
    """The one rule for a file vibra writes; return `path` as a Path when it may be written.

    Parameters
    ----------
    path : path-like
        The file to write.
    option : str
        The option that named it (``"--molden"``), put before the path in messages.
    inputs : iterable of path-like
        Files of this run that must not be written (besides those of `protected_inputs`).
    replace : bool
        Whether an existing regular file may be replaced.
    force_hint : str
        What the caller says to replace an existing file (``"--force"`` on the command line).

    Raises
    ------
    TargetRefused
        `path` is one of the inputs; a folder, device, FIFO, socket or symbolic link; an
        existing file with ``replace=False``; or below something that is not a folder.
    """
    target = Path(path)
    for source in (*_INPUTS.get(), *(Path(p) for p in inputs)):
        if _same_file(target, source):
            raise TargetRefused(path, f"is an input of this run ({source}); vibra never writes over its inputs; "
                                "expected another file name", option=option, code=errno.EEXIST)
    try:
        info = os.lstat(target)
    except FileNotFoundError:
        info = None
    except NotADirectoryError:
        info = None  # a parent is a file: said below
    except OSError as error:
        raise TargetRefused(path, f"cannot be inspected ({error.strerror}); expected a regular file or a new name",
                            option=option, code=error.errno or errno.EINVAL) from None
    if info is not None:
        if stat.S_ISLNK(info.st_mode):
            raise TargetRefused(path, f"is a symbolic link (to {os.readlink(target)}); vibra replaces regular files "
                                "only; give the real path or a new name", option=option)
        if not stat.S_ISREG(info.st_mode):
            code = errno.EISDIR if stat.S_ISDIR(info.st_mode) else errno.EINVAL
            raise TargetRefused(path, f"is {describe_kind(info.st_mode)}; vibra writes regular files only; expected "
                                "a file name (a regular file or a new name)", option=option, code=code)
        _refuse_system(path, target.parent, option, "is in")
        if not replace:
            raise TargetRefused(path, f"exists; {force_hint} replaces it (or give a new name)", option=option,
                                code=errno.EEXIST)
        return target
    for folder in target.parents:  # the nearest existing folder above must be a folder
        try:
            mode = os.stat(folder).st_mode
        except FileNotFoundError:
            continue
        except OSError as error:
            if error.errno == errno.ENOTDIR:
                continue
            raise TargetRefused(path, f"its folder {folder} cannot be inspected ({error.strerror})",
                                option=option, code=error.errno or errno.EINVAL) from None
        if not stat.S_ISDIR(mode):
            what = "a regular file" if stat.S_ISREG(mode) else describe_kind(mode)
            raise TargetRefused(path, f"its folder {folder} is {what}, not a folder; expected a path inside "
                                "a folder", option=option, code=errno.ENOTDIR)
        break
    _refuse_system(path, target.parent, option, "is in")
    return target


def check_out_folder(path: str | os.PathLike[str], *, option: str = "--out", create: bool = True) -> Path:
    """Check that the output folder `path` is, or can be created as, a writable folder outside the
    system folders; create it when missing (unless ``create=False``); return it.

    A folder writer then checks its own names and calls `claim_out_folder` before it writes.

    Raises
    ------
    TargetRefused
        `path` (or the nearest existing parent) is a file, device, FIFO, socket, dangling
        symlink or symlink loop; it is, lies in or would be created in a system folder
        (`system_folder`); it cannot be created, or is not writable.
    """
    target = Path(path)
    for folder in [target, *target.parents]:
        where = "" if folder == target else f"its parent {folder} "
        try:
            info = os.stat(folder)
        except FileNotFoundError:
            if os.path.islink(folder):
                raise TargetRefused(target, f"{where}is a symlink to a missing target ({os.readlink(folder)}); "
                                    "expected a folder (created when missing)", option=option,
                                    code=errno.ENOTDIR) from None
            continue
        except OSError as error:
            if error.errno == errno.ENOTDIR:
                continue
            what = "is a symlink loop" if error.errno == errno.ELOOP else f"cannot be inspected ({error.strerror})"
            raise TargetRefused(target, f"{where}{what}; expected a folder (created when missing)", option=option,
                                code=errno.ENOTDIR) from None
        if not stat.S_ISDIR(info.st_mode):
            what = "a regular file" if stat.S_ISREG(info.st_mode) else describe_kind(info.st_mode)
            raise TargetRefused(target, f"{where}is {what}; expected a folder (created when missing)", option=option,
                                code=errno.ENOTDIR)
        break
    _refuse_system(target, target, option, "is")
    if not create and not os.path.isdir(target):
        return target
    try:
        target.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise TargetRefused(target, f"cannot create the folder ({error.strerror}); expected a writable place",
                            option=option, code=error.errno or errno.EACCES) from None
    if not os.access(target, os.W_OK | os.X_OK):
        raise TargetRefused(target, f"the folder is not writable; choose another {option or 'folder'} or change its "
                            "permissions",
                            option=option, code=errno.EACCES)
    return target


def claim_out_folder(path: str | os.PathLike[str], *, option: str = "--out", force: bool = False,
                     force_hint: str = "--force", mark: bool = True) -> Path:
    """The ownership rule of an output folder: vibra writes into `path` only when it is empty,
    new, or vibra's own output (it holds the `OWN_MARK` folder ``.vibra/``), or when `force`;
    then (``mark=True``) it marks the folder as its own. Return `path`.

    Call it after `check_out_folder` and the writer's own checks, before the first write;
    ``mark=False`` checks only (before a long computation). A folder not there yet passes
    (it is created empty).

    Raises
    ------
    TargetRefused
        `path` holds entries and no ``.vibra/`` folder (a home folder, a project, a symlink to
        one), without `force`; or ``.vibra`` there is not a folder.
    """
    target = Path(path)
    marker = target / OWN_MARK
    try:
        names = sorted(os.listdir(target))
    except FileNotFoundError:
        return target  # not created yet: it will be empty
    except OSError as error:
        raise TargetRefused(target, f"cannot be listed ({error.strerror}); expected a folder vibra can read",
                            option=option, code=error.errno or errno.EACCES) from None
    try:
        own = stat.S_ISDIR(os.lstat(marker).st_mode)
    except FileNotFoundError:
        own = False
    else:
        if not own:
            raise TargetRefused(target, f"{marker} is not a folder; vibra marks its output folders with a {OWN_MARK}/ "
                                "folder; remove or rename it", option=option, code=errno.ENOTDIR)
    if names and not own and not force:
        more = f" and {len(names) - 1} more" if len(names) > 1 else ""
        link = f"(a symlink to {os.readlink(target)}) " if os.path.islink(target) else ""
        raise TargetRefused(target, f"{link}holds files vibra did not write ({names[0]!r}{more}) and no "
                            f"{OWN_MARK}/ mark; vibra writes only into a new or empty folder or one it wrote "
                            f"before; give such a folder, or {force_hint} to write there anyway", option=option,
                            code=errno.ENOTEMPTY)
    if mark and not own:
        try:
            marker.mkdir(exist_ok=True)
        except OSError as error:
            raise TargetRefused(target, f"cannot mark it as vibra's output ({error.strerror}); expected a writable "
                                "folder", option=option, code=error.errno or errno.EACCES) from None
    return target


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


def pid_alive(pid: int) -> bool:
    """True when process `pid` exists (signal 0 is sent only to check)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, under another user
        return True
    except OverflowError:
        return False
    return True


def remove_stale_temporaries(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files of `path` (``.<name>.<pid>~tmp~...`` beside it) whose writer no
    longer runs (a process killed mid-write, SIGKILL included); return what went.

    `atomic_write` calls it before each write, so the next write of the same file, by any
    command, cleans what a killed one left. A live writer's temporary file stays.
    """
    target = Path(path)
    prefix = f".{target.name}."
    removed: list[Path] = []
    try:
        entries = list(os.scandir(target.parent))
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(prefix) or TEMPORARY_MARK not in entry.name:
            continue
        owner = temporary_owner(entry.name)
        if owner is None or not entry.name.startswith(f"{prefix}{owner}{TEMPORARY_MARK}") or pid_alive(owner):
            continue  # another file's temporary (".a.png.x.<pid>~tmp~" is not a.png's), or a live writer's
        try:
            if entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            pass
    return removed


def atomic_write(path: str | os.PathLike[str], write: Callable[[Path], object], *,
                 suffix: str = ".tmp", option: str = "", inputs: Iterable[str | os.PathLike[str]] = (),
                 replace: bool = True, force_hint: str = "replace=True") -> Path:
    """Create `path` atomically: `write(temporary_path)` fills a temporary file, then it is renamed.

    Temporary files of `path` left by killed writers are removed first (`remove_stale_temporaries`).

    `path` is checked by `check_target` first (a regular file or a new name, never an input)
    and again just before the rename, so nothing else is ever replaced.

    Parameters
    ----------
    path : path-like
        The file to create or replace; its folder is created when missing.
    write : callable
        Called once with the temporary file's path (an empty file in the same folder); it
        writes the content there (``figure.savefig(p)``, ``image.save(p)``, ...).
    suffix : str
        Ending of the temporary name (some writers pick a format from it).
    option, inputs, replace, force_hint
        As in `check_target`.

    Returns
    -------
    Path
        `path`, now holding the complete file with mode 0666 less the umask.

    Raises
    ------
    TargetRefused
        What `check_target` refuses, or a folder that cannot be created or written in.
    """
    rules = {"option": option, "inputs": tuple(inputs), "replace": replace, "force_hint": force_hint}
    target = check_target(path, **rules)  # type: ignore[arg-type]
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(target)  # what a killed writer of this file left
        handle, name = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}{TEMPORARY_MARK}", suffix=suffix,
                                        dir=target.parent)
    except OSError as error:  # name the target, never the temporary file
        raise TargetRefused(path, f"cannot write in its folder {target.parent} ({error.strerror or error}); "
                            "expected a writable folder", option=option, code=error.errno or errno.EACCES) from None
    os.close(handle)
    temporary = Path(name)
    try:
        write(temporary)
        os.chmod(temporary, file_mode())  # mkstemp creates 0600 files
        check_target(path, **rules)  # type: ignore[arg-type]  # again: nothing else appeared there meanwhile
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return target


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, **rules: object) -> Path:
    """Write `data` to `path` atomically (see `atomic_write`; `rules` as in `check_target`)."""
    return atomic_write(path, lambda temporary: temporary.write_bytes(data), **rules)  # type: ignore[arg-type]


def atomic_write_text(path: str | os.PathLike[str], text: str, **rules: object) -> Path:
    """Write `text` (UTF-8) to `path` atomically (see `atomic_write`; `rules` as in `check_target`)."""
    return atomic_write_bytes(path, text.encode("utf-8"), **rules)
