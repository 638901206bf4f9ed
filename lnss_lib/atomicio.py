"""Atomic file writes: a temporary file in the target's folder, flushed, then ``os.replace``.

An interrupted or failed write (full disk, permission, kill) never destroys an existing file or
leaves a truncated one: the temporary file is removed on any error and the target is untouched.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

__all__ = ["atomic_path", "write_bytes_atomic", "write_text_atomic", "write_netcdf_atomic"]


@contextlib.contextmanager
def atomic_path(path, suffix: str = ""):
    """Yield a temporary path beside ``path``; on a clean exit move it onto ``path``, else delete it.

    For writers that want a file name (NetCDF engines, plotly, papermill): write the temporary path
    inside the ``with`` block. ``suffix`` ends the temporary's name, for writers that check it
    (papermill wants ``.ipynb``).
    """
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp{suffix}")
    try:
        yield temporary
        os.replace(temporary, path)
    except BaseException as error:
        with contextlib.suppress(OSError):
            temporary.unlink()
        if (
            isinstance(error, OSError) and error.errno is not None
        ):  # name the target, not the temporary file
            raise type(error)(error.errno, error.strerror or str(error), str(path)) from error
        raise


def write_bytes_atomic(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` (fsynced) through :func:`atomic_path`; returns ``path``."""
    with atomic_path(path) as temporary:
        with open(temporary, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
    return Path(path)


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through :func:`atomic_path`; returns ``path``."""
    return write_bytes_atomic(path, text.encode())


def write_netcdf_atomic(dataset, path) -> Path:
    """Write an xarray Dataset as NetCDF-4 (h5netcdf): serialised in memory, then :func:`write_bytes_atomic`,
    so a full disk is an ``OSError`` from a plain write, never a half-written HDF5 file."""
    return write_bytes_atomic(path, bytes(dataset.to_netcdf(engine="h5netcdf")))
