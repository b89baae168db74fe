"""Which recordings a batch runs, under which output names, and what it ran before.

* :func:`expand` turns paths, folders and glob patterns into a list of files;
* :func:`output_names` gives every file a unique output name (its stem, prefixed by as many
  parent folders as needed to tell files with the same stem apart);
* :class:`Manifest` (``DIR/.hyst-batch.json``) remembers, per output name, the content hash
  of the input and the options it was run with, so a rerun skips what is already done.
"""

from __future__ import annotations

import glob
import hashlib
import json
import os
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from app.services.runs.inputs import CommandError

__all__ = ["MANIFEST", "Manifest", "content_hash", "expand", "output_names"]

#: File name of the manifest inside the output folder.
MANIFEST = ".hyst-batch.json"
_RESERVED = {Path(MANIFEST).stem, "summary", "report"}
_GLOB_CHARS = set("*?[")


def expand(patterns: list[str | Path]) -> tuple[list[Path], list[str]]:
    """Files named by ``patterns``: paths, folders (their ``*.csv``) or globs (``**`` too).

    Returns
    -------
    files : list of Path
        In the order given (glob matches sorted), each file once. Paths that do not exist
        are kept: the batch records them as failed.
    unmatched : list of str
        Glob patterns that matched nothing.

    Raises
    ------
    CommandError
        If nothing at all was named.
    """
    files: list[Path] = []
    unmatched: list[str] = []
    for pat in map(str, patterns):
        p = Path(pat)
        if p.is_dir():
            got = sorted(q for q in p.glob("*.csv") if q.is_file())
            if not got:
                unmatched.append(pat)
        elif not p.exists() and _GLOB_CHARS & set(pat):
            got = sorted(Path(m) for m in glob.glob(pat, recursive=True) if Path(m).is_file())
            if not got:
                unmatched.append(pat)
        else:
            got = [p]
        files.extend(got)
    seen: set[str] = set()
    unique = []
    for f in files:
        key = os.path.realpath(f)
        if key not in seen:
            seen.add(key)
            unique.append(f)
    if not unique:
        raise CommandError(
            "no recordings: " + (f"nothing matches {', '.join(unmatched)}" if unmatched
                                 else "give CSV files, folders or glob patterns such as "
                                      "'data/*.csv'"))
    return unique, unmatched


def output_names(files: list[Path]) -> list[str]:
    """A unique output name per file: the stem, with parent folders when stems collide.

    ``a/run.csv`` and ``b/run.csv`` become ``a__run`` and ``b__run``; names the output
    folder uses itself (``summary``, ``report``) get a ``_1`` suffix. Deterministic for a
    given list of files.
    """
    parts = [Path(os.path.abspath(f)).parts for f in files]
    names = [Path(f).stem or "recording" for f in files]
    groups: dict[str, list[int]] = defaultdict(list)
    for i, n in enumerate(names):
        groups[n].append(i)
    for idx in groups.values():
        if len(idx) < 2:
            continue
        for k in range(1, max(len(parts[i]) for i in idx)):
            cand = {i: "__".join([*parts[i][-1 - k:-1], names[i]]) for i in idx}
            if len(set(cand.values())) == len(idx):
                break
        for j, i in enumerate(idx):
            names[i] = cand[i] if len(set(cand.values())) == len(idx) else f"{names[i]}_{j + 1}"
    names = [n.replace(os.sep, "_").lstrip("/") for n in names]
    taken = set(names)
    out = []
    for n in names:
        if n in _RESERVED:
            k = 1
            while f"{n}_{k}" in taken:
                k += 1
            taken.add(f"{n}_{k}")
            n = f"{n}_{k}"
        out.append(n)
    return out


def content_hash(path: Path) -> str:
    """SHA-256 of the file's bytes (hex)."""
    h = hashlib.sha256()
    with Path(path).open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@dataclass
class Manifest:
    """``DIR/.hyst-batch.json``: per output name, what produced it.

    Each entry is ``{"file", "content_sha256", "options_key", "status", "row"}`` where
    ``row`` is the recording's summary row (see :class:`app.batch.RecordingResult`).
    """

    path: Path
    entries: dict[str, dict[str, Any]]

    @classmethod
    def load(cls, folder: Path) -> Manifest:
        """Read the manifest of ``folder`` (empty when absent or unreadable)."""
        p = Path(folder) / MANIFEST
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
            entries = dict(doc["entries"]) if doc.get("version") == 1 else {}
        except (OSError, ValueError, KeyError, TypeError):
            entries = {}
        return cls(p, entries)

    def done(self, name: str, sha: str, options_key: str, outputs: list[Path]) -> bool:
        """Whether ``name`` was run successfully on the same content with the same options
        and its outputs still exist."""
        e = self.entries.get(name)
        return bool(e and e.get("status") == "ok" and e.get("content_sha256") == sha
                    and e.get("options_key") == options_key and all(p.is_file() for p in outputs))

    def record(self, name: str, entry: dict[str, Any]) -> None:
        """Store ``entry`` for ``name`` and rewrite the file atomically."""
        self.entries[name] = entry
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"version": 1, "entries": self.entries}, indent=1,
                                  allow_nan=True), encoding="utf-8")
        os.replace(tmp, self.path)
