"""Expand campaign sources (HDF5 sessions, CSV and UFF files, folders, globs) into capture references.

Only metadata is read here, on the client: the number of captures of each HDF5 session. The
records themselves are read on the workers (:mod:`station.campaign.tasks`), so a reference
is a path and an index, a few dozen bytes whatever the size of the capture.
"""

from __future__ import annotations

import glob
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

from station.errors import InputFileError

#: Suffixes a campaign reads (the readers of :data:`station.readers.READERS`).
SUFFIXES = (".csv", ".tsv", ".txt", ".uff", ".unv", ".mat", ".h5", ".hdf5")
#: Suffixes a folder is searched for (not ``.txt``: a folder's notes are not records; name
#: text records by a glob or one by one).
FOLDER_SUFFIXES = tuple(s for s in SUFFIXES if s != ".txt")
_HDF5 = (".h5", ".hdf5")
#: Files of several records (captures, load cases): ``FILE:N`` names one.
_MANY = _HDF5 + (".uff", ".unv")


@dataclass(frozen=True, order=True)
class CaptureRef:
    """One capture to process: a file and, for an HDF5 session, the capture index.

    Attributes
    ----------
    file : str
        Absolute path (the workers must see the same path: a shared file system on a cluster).
    capture : int or None
        0-based index in an HDF5 session; None for a CSV (one record per file) or for an HDF5
        file whose captures could not be listed (the worker then reports why).
    """

    file: str
    capture: int | None = None

    @property
    def spec(self) -> str:
        """``FILE`` or ``FILE:CAPTURE``, as ``station identify`` takes it."""
        return self.file if self.capture is None else f"{self.file}:{self.capture}"

    @property
    def key(self) -> tuple[str, int]:
        """Identity in the results table (``capture`` -1 when there is none)."""
        return (self.file, -1 if self.capture is None else int(self.capture))


def _has_magic(s: str) -> bool:
    return any(c in s for c in "*?[")


def _files(source: str) -> list[Path]:
    """The data files a source names, sorted; a glob or folder matching nothing is an error.

    Hidden files (``.name``: a session writer's lock or temporary files) are never sources.
    """
    if _has_magic(source):
        hits = sorted(Path(p) for p in glob.glob(source, recursive=True))
        files = [p for p in hits if p.is_file() and p.suffix.lower() in SUFFIXES and not p.name.startswith(".")]
        if not files:
            raise InputFileError(f"{source}: the pattern matches no {', '.join(SUFFIXES)} file")
        return files
    p = Path(source)
    if p.is_dir():
        files = sorted(q for q in p.rglob("*")
                       if q.is_file() and q.suffix.lower() in FOLDER_SUFFIXES and not q.name.startswith("."))
        if not files:
            raise InputFileError(f"{p}: the folder holds no {', '.join(FOLDER_SUFFIXES)} file")
        return files
    if not p.is_file():
        raise InputFileError(f"{p}: no such file, folder or pattern")
    if p.suffix.lower() not in SUFFIXES:
        raise InputFileError(f"{p}: unknown file type {p.suffix or '(none)'!r}; expected one of {', '.join(SUFFIXES)}")
    return [p]


def _refs_of_file(path: Path, capture: int | None) -> Iterator[CaptureRef]:
    file = os.path.abspath(path)
    if path.suffix.lower() not in _MANY:
        yield CaptureRef(file, None)
        return
    if capture is not None:
        yield CaptureRef(file, capture)
        return
    try:
        if path.suffix.lower() in _HDF5:
            from station.storage import check_file  # h5py only when there is a session

            indices = list(range(check_file(path)))
        else:
            from station.uff_reader import load_cases

            indices = load_cases(path)
    except (InputFileError, OSError):
        yield CaptureRef(file, None)  # the worker's read reports the problem as a row
        return
    if path.suffix.lower() not in _HDF5 and len(indices) == 1:
        yield CaptureRef(file, None)  # a UFF file of one load case: read as the file
        return
    for i in indices:
        yield CaptureRef(file, i)


def _split(source: str) -> tuple[str, int | None]:
    """``FILE.h5:N`` -> (FILE.h5, N); anything else unchanged."""
    head, sep, tail = source.rpartition(":")
    if sep and head.lower().endswith(_MANY) and tail.lstrip("-").isdigit() and not os.path.exists(source):
        return head, int(tail)
    return source, None


def expand_sources(sources: Iterable[str], exclude: str | os.PathLike[str] | None = None) -> list[CaptureRef]:
    """Every capture the sources name, in order, each once.

    Parameters
    ----------
    sources : iterable of str
        ``FILE.csv`` (``.tsv``, ``.txt``), ``FILE.h5`` (all its captures), ``FILE.h5:N``,
        ``FILE.uff`` (all its load cases), ``FILE.uff:N``, a folder (every file of
        :data:`FOLDER_SUFFIXES` below it) or a glob (``'runs/**/*.h5'``, quoted so that the shell
        leaves it).
    exclude : str or Path, optional
        A folder whose files are never sources (the campaign's own output folder, so that
        its ``results.csv`` is not read as a capture when it lies below a source folder).

    Returns
    -------
    list of CaptureRef

    Raises
    ------
    InputFileError
        A source that names no readable file (one line). A damaged HDF5 file is not an error
        here: it becomes one reference whose row carries the reason.
    """
    out: list[CaptureRef] = []
    seen: set[tuple[str, int]] = set()
    skip = os.path.abspath(exclude) + os.sep if exclude is not None else None
    for source in sources:
        base, capture = _split(source)
        for path in _files(base):
            if skip is not None and os.path.abspath(path).startswith(skip):
                continue
            for ref in _refs_of_file(path, capture):
                if ref.key not in seen:
                    seen.add(ref.key)
                    out.append(ref)
    return out
