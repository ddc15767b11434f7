"""Writing generated files: all of them or none, each replaced atomically; and JSON text."""

from __future__ import annotations

import errno
import json
import os
import tempfile
from collections.abc import Collection, Mapping
from json.encoder import encode_basestring_ascii
from pathlib import Path
from typing import Any

from ..errors import EnvironmentProblem, Location, error


def indented_json(value: Any, ascii: bool = True) -> str:
    """`json.dumps(value, indent=2, ensure_ascii=ascii)`, for values made of dicts with
    string keys, lists (or tuples) and JSON scalars, without json's pure-Python indenting
    encoder (which makes a generator frame per container: `analyse --format json` spent
    0.15 s of its 1.5 s in it at 10,000 features, and a model nested 600 deep exceeded
    Python's recursion limit). Iterative, however deep; a list of strings is written in
    one join; other scalars go through json itself."""
    from json.encoder import encode_basestring

    encode = encode_basestring_ascii if ascii else encode_basestring
    out: list[str] = []
    stack: list[Any] = [(value, "\n")]  # text to write (str), or (value, its newline) to expand
    while stack:
        item = stack.pop()
        if type(item) is str:
            out.append(item)
            continue
        value, newline = item
        inner = newline + "  "
        if isinstance(value, dict):
            if not value:
                out.append("{}")
                continue
            pieces: list[Any] = ["{"]
            comma = ""
            for key, member in value.items():
                if type(member) is str:  # (the common case, without an expansion of its own)
                    pieces.append(f"{comma}{inner}{encode(key)}: {encode(member)}")
                else:
                    pieces += [f"{comma}{inner}{encode(key)}: ", (member, inner)]
                comma = ","
            pieces.append(newline + "}")
            stack.extend(reversed(pieces))
        elif isinstance(value, (list, tuple)):
            if not value:
                out.append("[]")
            elif all(type(member) is str for member in value):
                out.append("[" + inner + ("," + inner).join(map(encode, value)) + newline + "]")
            else:
                pieces = ["["]
                comma = ""
                for member in value:
                    pieces += [comma + inner, (member, inner)]
                    comma = ","
                pieces.append(newline + "]")
                stack.extend(reversed(pieces))
        else:
            out.append(json.dumps(value, ensure_ascii=ascii))
    return "".join(out)


def write_if_changed(folder: Path, files: Mapping[str, str | bytes]) -> dict[str, bool]:
    """Write the files whose content differs (text as UTF-8, or bytes as they are); {name: written}.

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
            data = content if isinstance(content, bytes) else content.encode("utf-8", "backslashreplace")
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


GENERATIONS = ".{}.generations"  # beside the output folder: the folders it points to
LOCK = ".{}.lock"


def write_generation(folder: Path, files: dict[str, str], also_ours: Collection[str] = ()) -> dict[str, bool]:
    """Replace `files` in `folder` as one generation; {name: written}.

    For outputs that must agree with each other (a variant's lock file, header and loader):
    a reader sees the complete previous generation or the complete new one, never a mix,
    even if this process is killed at any moment, and two writers into one folder take
    turns. `folder` is a symbolic link to its current generation, a folder in
    `.<name>.generations/` beside it; a new generation is written beside the current one,
    files it shares byte for byte hard-linked (their times kept, so builds do not redo
    work), anything else the folder holds carried over, and then the link is replaced in
    one rename. Generations no link points to (an older one, or one a killed run left)
    are removed. A real folder in the way becomes the first generation, with everything it
    holds, if motivml made it (an earlier version's output: it holds one of `files`; or only
    what else motivml puts there, `also_ours`: a run's folder, pictures) or it is empty; any
    other is refused, untouched (a checkout named as the output would have become a link). So is a name that is not a plain folder name (`-o .`, a variant named `.`),
    before anything is made beside it.
    """
    import fcntl

    parent, name = folder.parent, folder.name
    if name in ("", ".", "..") or folder.resolve() == folder.resolve().parent:
        raise EnvironmentProblem(
            error(Location(str(folder)), "is not a plain folder name: choose an output folder by its name", "io")
        )
    store = parent / GENERATIONS.format(name)
    current_path = folder
    if folder.is_dir() and not folder.is_symlink():
        try:
            held = os.listdir(folder)
        except OSError as exc:
            raise EnvironmentProblem(
                error(Location(str(folder)), f"cannot read: {exc.strerror or exc}", "io")
            ) from None
        if held and not set(held) & set(files) and not set(held) <= set(also_ours):
            raise EnvironmentProblem(
                error(
                    Location(str(folder)),
                    f"is a folder motivml did not make (it holds {sorted(held)[0]!r} and none of the files "
                    "written here): choose another output folder",
                    "io",
                )
            )
    try:
        parent.mkdir(parents=True, exist_ok=True)
        with open(parent / LOCK.format(name), "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, or the process dies
            current = _current_generation(folder, store)
            encoded = {n: content.encode("utf-8", "backslashreplace") for n, content in files.items()}
            written = {n: not (current is not None and _same(current / n, data)) for n, data in encoded.items()}
            if current is not None and not any(written.values()):
                _remove_stale(store, parent, name, keep=current)
                return written
            for n in encoded:  # what would make the generation lose something, before writing any
                current_path = folder / n
                if current is not None and (current / n).exists() and not (current / n).is_file():
                    raise IsADirectoryError(errno.EISDIR, "something other than a file is in the way")
            store.mkdir(exist_ok=True)
            new = Path(tempfile.mkdtemp(dir=store, prefix="generation-"))
            os.chmod(new, 0o777 & ~_umask())
            for entry in os.scandir(current) if current is not None else ():
                if entry.name in encoded and written[entry.name]:
                    continue
                current_path = Path(entry.path)
                if entry.is_dir(follow_symlinks=False):
                    os.rename(entry.path, new / entry.name)  # a folder someone keeps here moves along
                else:
                    _link_or_copy(Path(entry.path), new / entry.name)
            for n, data in encoded.items():
                if written[n]:
                    current_path = folder / n
                    _write_new(new / n, data)
            _fsync_dir(new)
            current_path = folder
            _link(new, folder)  # the moment a reader sees the new generation
            _fsync_dir(parent)
            _remove_stale(store, parent, name, keep=new)
            return written
    except OSError as exc:
        raise EnvironmentProblem(
            error(Location(str(current_path)), f"cannot write: {exc.strerror or exc}", "io")
        ) from None


def _current_generation(folder: Path, store: Path) -> Path | None:
    """The folder holding the current generation (None: nothing written yet)."""
    if folder.is_symlink():
        target = folder.resolve()
        if target.parent != store.resolve() or not target.is_dir():
            raise EnvironmentProblem(
                error(
                    Location(str(folder)),
                    f"is a link to {target}, which motivml did not write: choose another output folder",
                    "io",
                )
            )
        return target
    first = store / "generation-first"
    if not folder.exists():
        if first.is_dir():  # a run was killed between moving a real folder here and linking it
            _link(first, folder)
            return first
        return None
    if not folder.is_dir():
        raise EnvironmentProblem(
            error(Location(str(folder)), "something other than a folder is in the way", "io")
        )
    store.mkdir(exist_ok=True)
    os.rename(folder, first)  # the real folder, with all it holds, becomes the first generation
    _link(first, folder)
    return first


def _link(generation: Path, folder: Path) -> None:
    """Point `folder` at `generation` in one rename (a reader sees the old link or the new one)."""
    link = folder.parent / f".{folder.name}.link-{os.getpid()}"
    if link.is_symlink():
        link.unlink()
    os.symlink(os.path.relpath(generation, folder.parent), link)
    os.replace(link, folder)


def _same(path: Path, data: bytes) -> bool:
    try:
        return path.is_file() and not path.is_symlink() and path.read_bytes() == data
    except OSError:
        return False


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _write_new(path: Path, data: bytes) -> None:
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666 & ~_umask())
    with os.fdopen(descriptor, "wb") as out:
        out.write(data)
        out.flush()
        os.fsync(out.fileno())


def _link_or_copy(source: Path, target: Path) -> None:
    import shutil

    try:
        os.link(source, target, follow_symlinks=False)
    except OSError:  # a file system without hard links
        shutil.copy2(source, target, follow_symlinks=False)


def _fsync_dir(path: Path) -> None:
    descriptor = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _remove_stale(store: Path, parent: Path, name: str, keep: Path) -> None:
    """Generations no link points to, and links a killed run left behind."""
    import shutil

    for entry in os.scandir(store):
        if Path(entry.path).resolve() != keep.resolve():
            shutil.rmtree(entry.path, ignore_errors=True)
    for entry in os.scandir(parent):
        if entry.name.startswith(f".{name}.link-") and entry.is_symlink():
            os.unlink(entry.path)
