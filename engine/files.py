"""Writing a file so that a failure names it and leaves nothing half-written under its name.

Every output of the workbench (checkpoints, sweep tables, VTU frames and their ``.pvd``,
PNGs, movies, reports, ParaView scripts) is written through :func:`replacing`: the bytes go
to a hidden temporary file beside the target (``.NAME.partPID.SUFFIX``, the suffix kept for
writers that choose a format by it), which is renamed onto the target only once complete.
A write that fails (a full disk, a quota, a read-only file system, an I/O error) removes the
temporary file and raises :class:`~engine.errors.WriteFailed`, whose ``str()`` is one line
naming the target and the cause; an older file of that name is left as it was.

HDF5 is a special case: the library cannot recover from a write that fails for want of
space (its metadata stay unwritten, h5py prints a traceback from every object it frees, and
the process may end in a segmentation fault).  A file written in one go (a checkpoint, a
table) is therefore built in memory (:func:`h5_image`) and written with plain file I/O; a
file appended to while a run goes on (a history) holds its next write's room in advance
(``engine.io``'s headroom).
"""
from __future__ import annotations

import errno as _errno
import os
import shutil
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

from .errors import WriteFailed

#: errnos of a write that the disk refused (``nscd`` exit 1 wherever they come from).
WRITE_ERRNOS = frozenset({_errno.ENOSPC, _errno.EDQUOT, _errno.EROFS, _errno.EIO,
                          _errno.EFBIG})


def errno_of(e: BaseException) -> int | None:
    """The errno of an OS or HDF5 write error (h5py puts it in the message text)."""
    if isinstance(e, OSError) and e.errno:
        return e.errno
    import re

    m = re.search(r"errno = (\d+)", str(e))
    return int(m.group(1)) if m else None


def write_cause(e: BaseException) -> str:
    """One line saying why a write failed (HDF5's messages span several lines)."""
    code = errno_of(e)
    if code:
        return f"{os.strerror(code)} ({_errno.errorcode.get(code, code)})"
    return " ".join(str(e).split())[:200]


def free_bytes(path) -> int:
    """Bytes a non-root user may still write on the file system of ``path`` (a file or a
    folder; the nearest existing parent folder is looked at)."""
    d = os.path.abspath(os.fspath(path))
    while not os.path.isdir(d):
        d = os.path.dirname(d)
    return shutil.disk_usage(d).free


def failed(path, e: BaseException, what: str = "could not be written") -> WriteFailed:
    """The :class:`WriteFailed` of ``path`` for the error ``e``: ``PATH: what (cause)``."""
    return WriteFailed(path, errno_of(e), f"{what} ({write_cause(e)})")


def _temporary(path: Path) -> Path:
    return path.with_name(f".{path.stem}.part{os.getpid()}{path.suffix}")


def leftovers(path) -> list[Path]:
    """The temporary files a killed writer of ``path`` left beside it (:func:`replacing`)."""
    import glob

    path = Path(path)
    return [Path(p) for p in glob.glob(glob.escape(str(path.with_name(f".{path.stem}.part")))
                                       + "[0-9]*")]


@contextmanager
def replacing(path, what: str = "could not be written") -> Iterator[Path]:
    """``with replacing(path) as tmp:`` write ``tmp``; on leaving, ``tmp`` replaces ``path``.

    The parent folder is created.  A write the disk refuses (:func:`is_write_error`: an
    OSError, or h5py's RuntimeError carrying such an errno) raises :class:`WriteFailed`
    naming ``path`` (and saying that an older file of that name is kept, or that nothing is
    left under it); any other error (a missing or forbidden folder, a bad value) is raised
    as it is, an OSError with the target as its file name.  Any failure removes ``tmp``;
    ``path`` is then as it was.  ``tmp`` has the target's suffix (writers that choose a
    format by it)."""
    path = Path(path)
    tmp = _temporary(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        yield tmp
        if not tmp.exists():
            raise FileNotFoundError(_errno.ENOENT, "the writer left no file", str(path))
        os.replace(tmp, path)
    except WriteFailed:
        raise
    except (OSError, RuntimeError) as e:
        if is_write_error(e):
            kept = ("the older file of this name is kept" if path.exists()
                    else "nothing is left under this name")
            raise WriteFailed(path, errno_of(e), f"{what} ({write_cause(e)}); {kept}") \
                from None
        if isinstance(e, OSError) and (e.filename is None
                                       or os.fspath(e.filename) == os.fspath(tmp)):
            e.filename = str(path)            # a path error names the target, not tmp
        raise
    finally:
        try:
            tmp.unlink()
        except FileNotFoundError:
            pass
        except OSError:                       # a read-only disk: there is nothing to remove
            pass


def write_bytes(path, data: bytes, what: str | None = None) -> Path:
    """Write ``data`` to ``path`` through :func:`replacing` (flushed to the disk before the
    rename, so that a crash after it finds the whole file)."""
    kw = {} if what is None else {"what": what}
    with replacing(path, **kw) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
    return Path(path)


def write_text(path, text: str, what: str | None = None) -> Path:
    """Write ``text`` (UTF-8) to ``path`` as :func:`write_bytes` does."""
    return write_bytes(path, text.encode("utf-8"), what)


def h5_image(build: Callable, **kwargs) -> bytes:
    """The bytes of an HDF5 file built in memory by ``build(f)`` (``f`` an open, writable
    ``h5py.File``; ``kwargs`` go to it, e.g. ``libver``): HDF5 then never meets a failing
    disk.  Write them with :func:`write_bytes`."""
    import io

    import h5py

    buf = io.BytesIO()
    with h5py.File(buf, "w", **kwargs) as f:
        build(f)
    return buf.getvalue()


def is_write_error(e: BaseException) -> bool:
    """True for an error a disk gives a write (:data:`WRITE_ERRNOS`), wherever it comes
    from: the command line reports it as a failed write (exit 1), not as bad input."""
    return isinstance(e, (OSError, RuntimeError)) and errno_of(e) in WRITE_ERRNOS


__all__ = ["replacing", "write_bytes", "write_text", "h5_image", "failed", "free_bytes",
           "errno_of", "write_cause", "is_write_error", "leftovers", "WRITE_ERRNOS"]
