"""Writing output files so that an interrupted run leaves nothing half-written.

Used by the ``ctrl-lpv`` commands and `ctrl_lpv.twomass.reproduce` (not
public). Everything is first written to a temporary file or folder beside
the destination (same file system), then moved into place with renames,
during which SIGINT and SIGTERM are held back. Only the standard library is
imported here: the command line imports this module before parsing.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
from pathlib import Path

__all__ = [
    "check_destination",
    "signals_deferred",
    "staged_file",
    "staged_folder",
    "temporary_beside",
    "usual_mode",
]


def check_destination(path: Path, name: str, *, folder: bool) -> None:
    """Refuse a destination that cannot be written, before any work.

    Parameters
    ----------
    path : path
        The file (``folder=False``) or folder (``folder=True``) to write.
        It may exist (a file is replaced, a folder receives the files); its
        parent folder must exist: no folder is created silently.
    name : str
        The option or argument, for the message (e.g. ``"--save"``).
    folder : bool
        Whether `path` is a folder.

    Raises
    ------
    ValueError
        Naming `name`: the parent is missing or not a folder, or cannot be
        written; `path` is a folder where a file is expected, or the reverse.
    """
    path = Path(path)
    parent = path.parent
    if not parent.exists():
        raise ValueError(
            f"{name}: the folder {parent} does not exist (it is not created: "
            "create it first or choose another path)"
        )
    if not parent.is_dir():
        raise ValueError(f"{name}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{name}: the folder {parent} is not writable")
    if folder and path.exists() and not path.is_dir():
        raise ValueError(f"{name}: {path} exists and is not a folder")
    if not folder and path.is_dir():
        raise ValueError(f"{name}: {path} is a folder; give a file name")


def usual_mode(path: Path) -> None:
    """Give a temporary file or folder the mode of one made by ``open``/``mkdir``.

    `tempfile` makes them private (0600, 0700); the result is an ordinary
    output, so it gets the process's default permissions.
    """
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, (0o777 if Path(path).is_dir() else 0o666) & ~umask)


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT and SIGTERM back while the block runs (a few renames).

    A signal that arrives meanwhile is delivered when the block ends, so a
    commit of several renames is never cut in the middle.
    """
    held = {signal.SIGINT, signal.SIGTERM}
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover (Windows)
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextlib.contextmanager
def temporary_beside(path: Path, *, folder: bool):
    """Yield a new temporary file or folder beside `path`, removed on failure.

    The caller moves it into place before the block ends. It is created with
    SIGINT and SIGTERM held back, so that it exists only once it is known
    here: an interruption at any point leaves nothing behind.
    """
    path = Path(path)
    prefix = f".{path.name}.partial-"
    work = None
    try:
        with signals_deferred():
            if folder:
                work = Path(tempfile.mkdtemp(prefix=prefix, dir=path.parent))
            else:
                handle, name = tempfile.mkstemp(prefix=prefix, dir=path.parent)
                os.close(handle)
                work = Path(name)
        yield work
    except BaseException:
        if work is not None and folder:
            shutil.rmtree(work, ignore_errors=True)
        elif work is not None:
            work.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def staged_file(path: Path):
    """Yield a temporary path beside `path`, renamed to `path` on success.

    On any error or interruption the temporary file is removed and `path`
    is left as it was.
    """
    with temporary_beside(path, folder=False) as work:
        yield work
        usual_mode(work)
        with signals_deferred():
            os.replace(work, path)


@contextlib.contextmanager
def staged_folder(path: Path):
    """Yield a temporary folder beside `path`; its files go to `path` on success.

    A missing `path` is created by renaming the temporary folder; an
    existing one receives the files (replacing those of the same names),
    the other files it holds are kept. On any error or interruption the
    temporary folder is removed and `path` is left as it was.
    """
    path = Path(path)
    with temporary_beside(path, folder=True) as work:
        yield work
        usual_mode(work)
        with signals_deferred():
            if path.exists():
                for item in work.iterdir():
                    os.replace(item, path / item.name)
                work.rmdir()
            else:
                work.rename(path)
