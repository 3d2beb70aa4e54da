"""One check for every command's output option: never overwrite an input or a file of another kind.

Every option that names a file or folder to write (``export --uff/--sep005``, ``import --out``,
``acquire --out``, ``diagnose --save-model/--report``, ``report --out``, ``demo --out``) calls
:func:`check_output` before anything is read or written. It refuses, with one line:

- an output that is one of the command's inputs (same file, also through a symlink or a hard
  link);
- an existing file of another kind (an HDF5 session file where a UFF, JSON or report is to be
  written, a folder where a file is to be written, ...), recognised by its first bytes;
- a file output whose folder does not exist, or cannot be written (a read-only mount), before any
  work is done.

Replacing a file of the same kind (re-exporting a UFF file) is allowed: that is what was asked.
JSON files are told apart by their first bytes: a station model (``--save-model``: an object
with ``schema_version``), a SEP-005 export (``--sep005``: a list of channel objects with
``data``) and any other JSON; ``export --sep005`` onto a saved model (or ``--save-model`` onto
an export) is refused (session 19: it replaced the model).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from station.errors import InputFileError

#: Kinds of output and the names shown to the user.
KINDS = {
    "hdf5": "an HDF5 file",
    "uff": "a UFF file",
    "json": "a JSON file",
    "model": "a station model file (JSON)",
    "sep005": "a SEP-005 JSON file",
    "csv": "a CSV file",
    "html": "an HTML file",
    "png": "a PNG image",
    "dir": "a folder",
}
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


class OutputRefused(InputFileError):
    """An output option names an input, a file of another kind, or a missing folder."""


def sniff(path: Path) -> str | None:
    """Kind of an existing path (a key of :data:`KINDS`), ``"empty"``, or None when unrecognised."""
    if path.is_dir():
        return "dir"
    try:
        with open(path, "rb") as fh:
            head = fh.read(512)
    except OSError:
        return None
    if not head:
        return "empty"
    if head.startswith(_HDF5_MAGIC):
        return "hdf5"
    if head.startswith(b"\x89PNG"):
        return "png"
    text = head.lstrip()
    if text[:1] in (b"{", b"["):
        return _json_kind(text)
    if text.startswith(b"-1") and head[:6].strip() == b"-1":
        return "uff"
    low = text[:64].lower()
    if low.startswith(b"<!doctype html") or low.startswith(b"<html"):
        return "html"
    first = head.split(b"\n", 1)[0]
    if b"," in first and first.replace(b",", b"").replace(b"_", b"").strip().isalnum():
        return "csv"
    return None


def _json_kind(text: bytes) -> str:
    """``"model"`` (a station model: an object whose first key is ``schema_version`` or
    ``kind``, as :meth:`EquationOfMotion.to_dict` and the modal-sum model write),
    ``"sep005"`` (a list of objects, as ``station export --sep005`` writes) or ``"json"``."""
    body = text[1:].lstrip()
    if text[:1] == b"{" and (body.startswith(b'"schema_version"') or body.startswith(b'"kind"')):
        return "model"
    if text[:1] == b"[" and body.startswith(b"{") and b'"data"' in text:
        return "sep005"
    return "json"


def _file_of(spec: str | os.PathLike[str]) -> Path:
    """The file of an input spec (``FILE`` or ``FILE:CAPTURE``)."""
    p = Path(spec)
    if p.exists():
        return p
    head, sep, _ = str(spec).rpartition(":")
    return Path(head) if sep and head else p


def _same(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_output(out: str | os.PathLike[str], kind: str, inputs: Iterable[str | os.PathLike[str]] = (), *,
                 option: str = "--out", append: bool = False) -> Path:
    """Refuse an output that would destroy an input or a file of another kind (one line).

    Parameters
    ----------
    out : str or Path
        The file or folder the option names.
    kind : str
        What will be written there, a key of :data:`KINDS` (``"dir"`` for a folder).
    inputs : iterable of str or Path
        The command's input files (``FILE`` or ``FILE:CAPTURE``).
    option : str
        The option's name, for the message.
    append : bool
        The output is appended to (a session file): being an existing HDF5 file is expected,
        and it may not be an input either.

    Returns
    -------
    Path

    Raises
    ------
    OutputRefused
    """
    p = Path(out)
    what = KINDS[kind]
    found: str | None = None
    for spec in inputs:
        src = _file_of(spec)
        if _same(p, src):
            raise OutputRefused(f"{option} {p}: is the input {spec}; refusing to overwrite an input, "
                                f"choose another name")
    if p.exists() or p.is_symlink():
        found = sniff(p) if p.exists() else None
        if p.is_symlink() and not p.exists():
            raise OutputRefused(f"{option} {p}: is a dangling symbolic link; expected a new name or {what}")
        if found not in (kind, "empty") and not (kind == "dir" and found == "dir"):
            shown = KINDS.get(found or "", "a file of another kind") if found != "dir" else "a folder"
            raise OutputRefused(f"{option} {p}: exists and is {shown}; refusing to replace it with {what} "
                                f"(choose another name, or remove it first)")
    elif kind != "dir" and not p.parent.is_dir():
        raise OutputRefused(f"{option} {p}: the folder {p.parent} does not exist; create it first")
    elif kind == "dir" and p.parent != p and not p.parent.is_dir():
        raise OutputRefused(f"{option} {p}: the folder {p.parent} does not exist; create it first")
    if not append:  # refused now, not after the work (a diagnosis took 37 s to fail on a read-only folder)
        folder = p if kind == "dir" and p.is_dir() else p.parent
        if folder.is_dir() and not os.access(folder, os.W_OK):
            raise OutputRefused(f"{option} {p}: the folder {folder} cannot be written (read-only or not "
                                f"permitted); choose another folder")
    if append and p.exists():
        if found is None:  # created since the first look (another writer): look again
            found = sniff(p)
        if found not in ("hdf5", "empty"):
            raise OutputRefused(f"{option} {p}: exists and is not an HDF5 session file")
    return p


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all: into a temporary file beside it, then
    renamed over it. A full disk, a file-size limit or Ctrl-C while writing leaves the file that
    was there (a model saved before) as it was, and no temporary file (``--save-model`` onto an
    existing model truncated it first and then failed, session 19).

    Raises
    ------
    OSError
        Naming ``path`` (not the temporary file).
    """
    dest = Path(path)
    if dest.is_symlink():  # written through the link, as an in-place write was (the link stays)
        dest = dest.resolve()
    tmp = dest.with_name(f".{dest.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, dest)
    except BaseException as exc:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:  # a read-only folder refuses even this
            pass
        if isinstance(exc, OSError):
            raise OSError(exc.errno, exc.strerror or str(exc), str(dest)) from None
        raise


__all__ = ["KINDS", "OutputRefused", "check_output", "sniff", "write_text_atomic"]
