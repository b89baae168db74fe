"""Recordings, train/test splits and the conditioning variables of the residual battery."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._typing import Float1D
from ..exceptions import ParameterError
from ..validation import as_input_signal

__all__ = [
    "Record",
    "as_records",
    "crossfit_folds",
    "load_csv",
    "reversal_points",
    "split_masks",
    "wipeout_index",
]


@dataclass(frozen=True, eq=False)
class Record:
    """One recording ``(t, u, y)`` on a uniform time grid.

    Attributes
    ----------
    t : ndarray of shape (N,)
        Time in seconds (uniformly spaced).
    u, y : ndarray of shape (N,)
        Input and measured output.
    name : str
        Label used in reports (file stem).
    """

    t: Float1D
    u: Float1D
    y: Float1D
    name: str = "recording"

    def __post_init__(self) -> None:
        t = as_input_signal(self.t, "t")
        u = as_input_signal(self.u, "u")
        y = as_input_signal(self.y, "y")
        if not (t.size == u.size == y.size):
            raise ParameterError(
                f"recording {self.name!r}: t, u and y must have the same length, got "
                f"{t.size}, {u.size}, {y.size}"
            )
        if t.size < 20:
            raise ParameterError(f"recording {self.name!r} has {t.size} samples; need >= 20")
        d = np.diff(t)
        dt = float(np.median(d))
        if dt <= 0 or np.max(np.abs(d - dt)) > 0.01 * dt:
            raise ParameterError(
                f"recording {self.name!r}: time must increase uniformly (dt = {dt:g} s, largest "
                f"deviation {np.max(np.abs(d - dt)):g} s); resample it onto a uniform grid first"
            )
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "y", y)

    @property
    def dt(self) -> float:
        """Sample spacing in seconds."""
        return float((self.t[-1] - self.t[0]) / (self.t.size - 1))

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)


def load_csv(path: str | Path) -> Record:
    """Read a recording CSV (header row; columns time, input, output, ...).

    Uses :mod:`core.csvio` when available, else plain numpy (first three columns).
    """
    p = Path(path)
    if not p.is_file():
        raise ParameterError(f"recording file {str(p)!r} does not exist")
    try:
        data = np.loadtxt(p, delimiter=",", skiprows=1, usecols=(0, 1, 2), ndmin=2)
    except ValueError as exc:
        raise ParameterError(
            f"{p.name}: expected a CSV with a header row and numeric columns time, input, "
            f"output: {exc}"
        ) from exc
    return Record(data[:, 0], data[:, 1], data[:, 2], p.stem)


def as_records(data: Any) -> list[Record]:
    """Normalise the accepted inputs of :func:`~core.diagnosis.diagnose` to a list of records.

    Accepts a :class:`Record`, an object with ``t``, ``u``, ``y`` attributes (e.g.
    ``core.recordings.Recording``), a ``(t, u, y)`` tuple, a CSV path, or a list of those.
    """
    if isinstance(data, Record | str | Path) or _is_triplet(data) or hasattr(data, "u"):
        data = [data]
    if not isinstance(data, Sequence) or len(data) == 0:
        raise ParameterError("diagnose needs at least one recording (t, u, y)")
    out = []
    for i, d in enumerate(data):
        if isinstance(d, Record):
            out.append(d)
        elif isinstance(d, str | Path):
            out.append(load_csv(d))
        elif hasattr(d, "u") and hasattr(d, "y") and hasattr(d, "t"):
            out.append(Record(d.t, d.u, d.y, str(getattr(d, "name", f"recording{i + 1}"))))
        elif _is_triplet(d):
            out.append(Record(d[0], d[1], d[2], f"recording{i + 1}"))
        else:
            raise ParameterError(
                f"recording {i} is a {type(d).__name__}; pass (t, u, y) arrays, a Record or a "
                "CSV path"
            )
    return out


def _is_triplet(d: Any) -> bool:
    return isinstance(d, tuple | list) and len(d) == 3 and all(
        np.ndim(x) == 1 and np.size(x) > 3 for x in d
    )


def split_masks(
    records: Sequence[Record],
    train: tuple[float, float] | None = None,
    test: tuple[float, float] | None = None,
    n_blocks: int = 8,
    min_block_s: float = 0.5,
) -> tuple[list[np.ndarray], list[np.ndarray], str]:
    """Boolean train/test masks per recording.

    With explicit ``train``/``test`` time ranges ``(t0, t1)`` (seconds, half-open) they are
    applied to every recording. Otherwise each recording is cut into ``n_blocks`` interleaved
    blocks (at least ``min_block_s`` long), alternating train/test, starting with train.

    Returns
    -------
    train_masks, test_masks : list of ndarray of bool
    description : str
    """
    trm, tem = [], []
    if train is not None or test is not None:
        if train is None or test is None:
            raise ParameterError("give both --train T0:T1 and --test T0:T1, or neither")
        for r in records:
            a = (r.t >= train[0]) & (r.t < train[1])
            b = (r.t >= test[0]) & (r.t <= test[1])
            trm.append(a)
            tem.append(b)
        if sum(int(m.sum()) for m in trm) < 50 or sum(int(m.sum()) for m in tem) < 20:
            raise ParameterError(
                f"train {train} / test {test} select too few samples; the recordings span "
                + ", ".join(f"{r.t[0]:g}..{r.t[-1]:g} s" for r in records)
            )
        desc = f"train t in [{train[0]:g}, {train[1]:g}) s, test t in [{test[0]:g}, {test[1]:g}] s"
        return trm, tem, desc
    for r in records:
        dur = r.t[-1] - r.t[0]
        nb = int(max(2, min(n_blocks, dur // min_block_s)))
        idx = np.minimum((np.arange(r.n) * nb) // r.n, nb - 1)
        trm.append(idx % 2 == 0)
        tem.append(idx % 2 == 1)
    desc = f"interleaved blocks ({n_blocks} per recording, alternating train/test)"
    return trm, tem, desc


def reversal_points(u: Float1D, tol: float) -> np.ndarray:
    """Indices of input reversals (turning points), ignoring wiggles smaller than ``tol``."""
    idx = [0]
    direction = 0
    ext = float(u[0])
    ext_i = 0
    for k in range(1, u.size):
        v = float(u[k])
        if direction >= 0 and v > ext:
            ext, ext_i = v, k
            if direction == 0 and v - u[0] > tol:
                direction = 1
        elif direction <= 0 and v < ext:
            ext, ext_i = v, k
            if direction == 0 and u[0] - v > tol:
                direction = -1
        if direction == 1 and ext - v > tol:
            idx.append(ext_i)
            direction, ext, ext_i = -1, v, k
        elif direction == -1 and v - ext > tol:
            idx.append(ext_i)
            direction, ext, ext_i = 1, v, k
    return np.unique(np.asarray(idx, dtype=np.int64))


def wipeout_index(u: Float1D, frac: float = 0.98) -> int:
    """First sample after which the input has visited both ends of its range (t_w)."""
    lo, hi = float(u.min()), float(u.max())
    span = hi - lo
    if span <= 0:
        return 0
    a = np.flatnonzero(u >= hi - (1 - frac) * span)
    b = np.flatnonzero(u <= lo + (1 - frac) * span)
    if a.size == 0 or b.size == 0:
        return u.size
    return int(max(a[0], b[0]))


def crossfit_folds(
    records: Sequence[Record],
    train: Sequence[np.ndarray],
    min_block_s: float = 0.5,
    max_blocks: int = 8,
) -> list[tuple[list[np.ndarray], list[np.ndarray]]]:
    """Blocked cross-validation folds over the training rows (after the wipe-out time).

    The training rows of each recording that come after its wipe-out time
    (:func:`wipeout_index`) are cut into contiguous blocks of at least ``min_block_s``
    seconds (at most ``max_blocks`` in all); each fold holds one block out. Rows before the
    wipe-out time are kept in every fold's training rows: their prediction depends on the
    unknown initial memory state, which is judged separately.

    Parameters
    ----------
    records : sequence of Record
    train : sequence of ndarray of bool
        Training rows per recording.
    min_block_s : float
        Shortest block (s).
    max_blocks : int
        Largest number of folds.

    Returns
    -------
    list of (train_masks, block_masks)
        Per fold, the training masks without the block and the block masks (per recording).
        Empty when fewer than two blocks fit.
    """
    spans = []
    for k, (r, m) in enumerate(zip(records, train, strict=True)):
        keep = m.copy()
        keep[: wipeout_index(r.u)] = False
        idx = np.flatnonzero(keep)
        if idx.size:
            spans.append((k, idx, idx.size * r.dt))
    total = sum(s for _, _, s in spans)
    nb_total = int(min(max_blocks, total // min_block_s))
    if nb_total < 2:
        return []
    folds: list[tuple[list[np.ndarray], list[np.ndarray]]] = []
    for k, idx, dur in spans:
        nb = int(round(nb_total * dur / total))
        if nb < 1 or dur < min_block_s:
            continue
        edges = np.linspace(0, idx.size, nb + 1).astype(int)
        for i in range(nb):
            blocks = [np.zeros(r.n, dtype=bool) for r in records]
            blocks[k][idx[edges[i] : edges[i + 1]]] = True
            folds.append(([m & ~b for m, b in zip(train, blocks, strict=True)], blocks))
    return folds if len(folds) >= 2 else []
