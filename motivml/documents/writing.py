"""Writing generated files: all of them or none, each replaced atomically."""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path

from ..errors import EnvironmentProblem, Location, error


def write_if_changed(folder: Path, files: dict[str, str]) -> dict[str, bool]:
    """Write the files whose content differs; {name: written}.

    Every changed file is first written to a temporary file beside its target, and only
    when all of them are written are they renamed over the targets, so a failure (a full
    disk, a folder in the way) leaves the earlier output as it was. New files get the
    usual permissions (0666 less the umask), not mkstemp's owner-only ones.
    """
    umask = os.umask(0)
    os.umask(umask)
    staged: list[tuple[str, Path]] = []
    written: dict[str, bool] = {}
    current = folder
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name, content in files.items():
            current = folder / name
            data = content.encode("utf-8", "backslashreplace")
            if current.is_file() and current.read_bytes() == data:
                written[name] = False
                continue
            handle, temporary = tempfile.mkstemp(dir=folder, prefix=f".{name}.", suffix=".tmp")
            staged.append((temporary, current))
            with os.fdopen(handle, "wb") as out:
                out.write(data)
            os.chmod(temporary, 0o666 & ~umask)
            written[name] = True
        for _, target in staged:  # what would make a rename fail, before the first rename
            current = target
            if target.exists() and not target.is_file():
                raise IsADirectoryError(errno.EISDIR, "something other than a file is in the way")
        for temporary, target in staged:
            current = target
            os.replace(temporary, target)
        return written
    except OSError as exc:
        raise EnvironmentProblem(
            error(Location(str(current)), f"cannot write: {exc.strerror}", "io")
        ) from None
    finally:
        for temporary, _ in staged:
            if os.path.exists(temporary):
                os.unlink(temporary)
