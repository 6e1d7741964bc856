"""Writing outputs so that a reader never sees half a file.

Every file a run produces is written to a temporary name in the same folder
and renamed into place, so an interruption leaves either the old file or the
new one.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import pandas as pd

from .errors import CranktrackError


def ensure_dir(path: str | os.PathLike) -> Path:
    """Create ``path`` (and parents) or say clearly why it cannot be."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except FileExistsError as e:
        raise CranktrackError(
            f"{p} exists and is not a folder; choose another output folder") from e
    except PermissionError as e:
        raise CranktrackError(f"cannot create the folder {p}: permission denied") from e
    except NotADirectoryError as e:
        raise CranktrackError(f"cannot create the folder {p}: a part of its path is a file, "
                              "not a folder") from e
    except OSError as e:  # a read-only filesystem, a path under /proc, a full disk, …
        raise CranktrackError(f"cannot create the folder {p} ({e.strerror or e}); choose "
                              "another output folder") from e
    if not os.access(p, os.W_OK):
        raise CranktrackError(f"the folder {p} is not writable; choose another output folder")
    return p


def write_text_atomic(path: str | os.PathLike, text: str | bytes) -> Path:
    """Write ``text`` (or bytes) to ``path`` via a temporary file and an atomic rename."""
    p = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".partial", dir=p.parent)
    except OSError as e:
        raise CranktrackError(f"cannot write {p}: {e.strerror}") from e
    try:
        if isinstance(text, bytes):
            with os.fdopen(fd, "wb") as f:
                f.write(text)
        else:
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
                f.write(text)
        # mkstemp makes the file private; give it the permissions a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, p)
    except OSError as e:
        Path(tmp).unlink(missing_ok=True)
        hint = "; the disk may be full" if e.errno == errno.ENOSPC else ""
        raise CranktrackError(f"could not write {p}: {e.strerror}{hint}; files written "
                              "before it are kept") from e
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return p


def write_csv_atomic(path: str | os.PathLike, table: pd.DataFrame) -> Path:
    """Write a table as CSV (full float precision, no index) atomically."""
    return write_text_atomic(path, table.to_csv(index=False, float_format="%.10g"))


def write_parquet_atomic(path: str | os.PathLike, table: pd.DataFrame) -> Path:
    """Write a table as Parquet (pyarrow, no index) atomically."""
    import io

    buffer = io.BytesIO()
    table.to_parquet(buffer, engine="pyarrow", index=False)
    return write_text_atomic(path, buffer.getvalue())


def write_json_atomic(path: str | os.PathLike, data: Any) -> Path:
    """Write JSON (indented, UTF-8) atomically."""
    return write_text_atomic(path, json.dumps(data, indent=2, allow_nan=True) + "\n")


def replace_folder(path: str | os.PathLike, stamp: str) -> Path:
    """Empty ``path`` for a new run of a command that owns it, or make it.

    A folder is cleared only if it holds the file ``stamp`` (which this writes), so a
    folder of the user's that happens to have the same name is never deleted.
    """
    p = Path(path)
    ours = (p / stamp).is_file()
    empty = p.is_dir() and not any(p.iterdir())
    if p.exists() and not (ours or empty):
        raise CranktrackError(f"{p} exists and was not made by cranktrack; move it away or "
                              "give another folder with --out")
    if ours:
        try:
            shutil.rmtree(p)
        except OSError as e:
            raise CranktrackError(f"cannot clear the old {p} ({e.strerror or e}); remove it by "
                                  "hand") from e
    folder = ensure_dir(p)
    write_text_atomic(folder / stamp, "made by cranktrack; the next run clears this folder\n")
    return folder
