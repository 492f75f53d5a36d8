"""What a command writes, checked before any work, and what it draws on the terminal.

Files are written to a temporary name and renamed, so an existing file is replaced only by
a whole new one, and a command's outputs can be renamed together at its end
(:func:`all_or_none`); folders a command created are removed again when it fails; optional
packages are checked before any work, naming the extra that installs them; progress bars
(tqdm) are drawn only on a terminal.
"""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..errors import InputError

# Folders this command created (removed again, when still empty, if it fails).
CREATED: list[Path] = []
# Files this command reads (set from its arguments by the command line's main): no output
# may name one (it would be overwritten by what was made from it).
INPUTS: list[Path] = []
# The output files this command has checked so far, and the option naming each: two
# options may not name one file (the second would replace the first's).
OUTPUTS: dict[str, str] = {}
# While all_or_none() runs: the files written in it, (temporary, target), renamed at its end.
_STAGED: list[list[tuple[Path, Path]]] = []
# The progress bar now drawn, if any (an error must close it and start on a fresh line).
_BAR: list[Any] = []


def is_terminal(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


def check_output_file(path: Path | None, option: str) -> None:
    """Refuse, before any work, an output file that cannot be written."""
    if path is None or str(path) == "-":
        return
    if path.is_dir():
        raise InputError(f"cannot write {option} {path}: it is a folder; give a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"cannot write {option} {path}: the folder {parent} does not exist; create it first")
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise InputError(f"cannot write {option} {path}: permission denied")
    if path.exists() and any(source.exists() and os.path.samefile(path, source) for source in INPUTS):
        # it would be overwritten by what was made from it
        raise InputError(f"{option} {path} is one of the inputs; give another file name")
    key = os.path.realpath(path)
    if OUTPUTS.setdefault(key, option) != option:
        raise InputError(f"{option} {path} is also {OUTPUTS[key]}'s file; give each output its own file")


def check_output_files(folder: Path, names: tuple[str, ...], option: str) -> None:
    """:func:`check_output_file` of each of the files a command writes into ``folder``
    (named ``option``) under fixed names, before any work: a folder of one of those names
    failed a command at its end, after its other files were written."""
    for name in names:
        check_output_file(folder / name, option)


def check_output_dir(path: Path, option: str) -> None:
    """Refuse, before any work, an output folder that cannot be created or written."""
    if path.exists() and not path.is_dir():
        raise InputError(f"{option} {path} exists and is not a folder")
    existing = path
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"{option} {path}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"{option} {path}: {existing} is not writable")


def make_dir(path: Path, option: str) -> None:
    """Create an output folder (and its parents); remembered so a failure removes them."""
    check_output_dir(path, option)
    top = path
    while not top.parent.exists() and top.parent != top:
        top = top.parent
    created = not top.exists()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create {option} folder {path}: {exc.strerror}") from None
    if created:
        CREATED.append(top)


def remove_created() -> None:
    """Remove the folders this command created when they hold no file."""
    while CREATED:
        top = CREATED.pop()
        try:
            for root, dirs, files in os.walk(top, topdown=False):
                if files:
                    return
                for d in dirs:
                    (Path(root) / d).rmdir()
            top.rmdir()
        except OSError:
            pass


def replace_from_temp(target: Path, write: Any) -> None:
    """``write(tmp_path)`` then rename onto ``target``: an existing file is replaced only by a
    whole new one, and a failed write leaves nothing behind. The new file has the mode of
    the one it replaces, or what the umask gives a new file (``mkstemp`` makes it 0600).
    Inside :func:`all_or_none` the rename waits for the end of that block. A target that is
    a link is written where it leads (the link stays a link, as a shell's ``>`` keeps it)."""
    if target.is_symlink():
        target = Path(os.path.realpath(target))
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix, dir=target.parent or ".")
    except OSError as exc:
        raise InputError(f"cannot write {target}: {exc.strerror}") from None
    os.close(fd)
    staged = False
    try:
        write(Path(tmp))
        if _STAGED:
            _STAGED[-1].append((Path(tmp), target))
            staged = True
        else:
            _rename_onto(Path(tmp), target)
    except OSError as exc:  # named by the file asked for, not the temporary one
        raise InputError(f"cannot write {target}: {exc.strerror}") from None
    finally:
        if not staged and os.path.exists(tmp):
            os.unlink(tmp)


def _rename_onto(tmp: Path, target: Path) -> None:
    os.chmod(tmp, _mode_for(target))
    os.replace(tmp, target)


@contextlib.contextmanager
def all_or_none() -> Iterator[None]:
    """The files written with :func:`replace_from_temp` inside this block are renamed onto
    their names only when the block ends without an error (or Ctrl-C): a command whose
    last output fails leaves none of the earlier ones new, and every file it would have
    replaced as it was. Only a rename failing at the end (beside a file just written in
    the same folder) could leave some renamed. What closes inside the block (the message
    files of :func:`~stereo_terrain.cli.sinks.single_sinks`) closes before these renames,
    so the outputs that may fail while closing go there."""
    pending: list[tuple[Path, Path]] = []
    _STAGED.append(pending)
    try:
        yield
    except BaseException:
        _drop(pending)
        raise
    finally:
        _STAGED.pop()  # the innermost block: its own list
    for k, (tmp, target) in enumerate(pending):
        try:
            _rename_onto(tmp, target)
        except OSError as exc:
            _drop(pending[k:])
            raise InputError(f"cannot write {target}: {exc.strerror}") from None


def _drop(pending: list[tuple[Path, Path]]) -> None:
    for tmp, _ in pending:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _mode_for(target: Path) -> int:
    """The permission bits ``target`` should get: its own when it exists, else those of a
    new file under the process's umask."""
    try:
        return target.stat().st_mode & 0o7777
    except OSError:
        return 0o666 & ~_umask()


def _umask() -> int:
    """The process's umask: read from /proc where it can be (Linux), else set and set back
    (which leaves it 0 for an instant, for every thread)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    umask = os.umask(0)
    os.umask(umask)
    return umask


def require(module: str, extra: str, what: str, skip: str = "") -> None:
    """An optional dependency, checked before any work."""
    try:
        importlib.import_module(module)
    except ImportError:
        alt = f", or pass {skip}" if skip else ""
        raise InputError(
            f"{what} needs the Python package '{module}', which is not installed: "
            f"pip install 'stereo-terrain[{extra}]'{alt}"
        ) from None


def require_viz(what: str, skip: str = "") -> None:
    require("matplotlib", "viz", what, skip)


def require_lcm(what: str, skip: str = "") -> None:
    require("lcm", "lcm", what, skip)


def write_json(data: dict[str, Any], target: Path) -> None:
    """``data`` as indented JSON to ``target`` (replaced whole), or to stdout for ``-``."""
    text = json.dumps(data, indent=2)
    if str(target) == "-":
        print(text)
        return
    replace_from_temp(target, lambda tmp: tmp.write_text(text + "\n"))


def progress(done: int, total: int, text: str = "") -> None:
    """Advance the progress bar to ``done`` of ``total`` (tqdm, on stderr, only when it is a
    terminal); the bar opens on the first call and closes when ``done == total``."""
    if not is_terminal(sys.stderr):
        return
    if not _BAR or _BAR[0].total != total:
        end_progress()
        from tqdm import tqdm

        _BAR.append(tqdm(total=total, file=sys.stderr, leave=True, dynamic_ncols=True))
    bar = _BAR[0]
    bar.n = done
    bar.set_postfix_str(text[:60], refresh=False)
    bar.refresh()
    if done >= total:
        end_progress()


def end_progress() -> None:
    """Close an open progress bar (before an error line, or when the work ends)."""
    while _BAR:
        _BAR.pop().close()
