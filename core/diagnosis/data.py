"""Recordings, train/test splits and the conditioning variables of the residual battery."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..csvio import CsvOptions, read_csv
from ..exceptions import ParameterError
from ..fitting.thresholds import wipeout_index
from ..recordings import Recording

__all__ = [
    "GAP_FACTOR",
    "TimeGapError",
    "as_records",
    "crossfit_folds",
    "split_masks",
    "wipeout_index",
]

#: A spacing more than this many times the median one is a gap, not jitter: an error.
GAP_FACTOR = 2.0

#: Fewest samples a recording needs to be diagnosed.
MIN_SAMPLES = 20

#: Interleaved train/test blocks per recording of the default split (:func:`split_masks`),
#: and the shortest block (s) of that split and of the cross-fitting folds
#: (:func:`crossfit_folds`, at most :data:`MAX_FOLDS` blocks).
SPLIT_BLOCKS = 8
MIN_BLOCK_S = 0.5
MAX_FOLDS = 8
#: A ``min_block_s`` that lets blocks of any length through (recordings too short for
#: :data:`MIN_BLOCK_S`).
ANY_BLOCK_S = 1e-12
#: Fewest training and test rows explicit time windows must select.
MIN_WINDOW_TRAIN_ROWS = 50
MIN_WINDOW_TEST_ROWS = 20


class TimeGapError(ParameterError):
    """A recording's time stamps jump by more than :data:`GAP_FACTOR` times their usual
    spacing: the diagnosis needs even samples. The message says what to do in general
    terms (cut the file, or resample); each interface adds its own way to resample.

    Attributes
    ----------
    name : str
        The recording.
    gap_s, spacing_s : float
        The jump and the usual (median) spacing, in s.
    t0_s, t1_s : float
        Time stamps either side of the jump, in s.
    line : int or None
        Line of the file after the jump, when known.
    """

    def __init__(self, name: str, gap_s: float, spacing_s: float, t0_s: float, t1_s: float,
                 line: int | None) -> None:
        where = f" (line {line} of the file)" if line is not None else ""
        super().__init__(
            f"recording {name!r}: the time stamps jump by {gap_s:.6g} s from t = {t0_s:.6g} s "
            f"to t = {t1_s:.6g} s{where}, {gap_s / spacing_s:.3g} times the usual spacing of "
            f"{spacing_s:.6g} s; the diagnosis needs evenly spaced samples: cut the recording "
            "at the gap into two files, or resample it onto an even grid (interpolating "
            "across the gap)")
        self.name, self.gap_s, self.spacing_s = name, gap_s, spacing_s
        self.t0_s, self.t1_s, self.line = t0_s, t1_s, line


def as_records(data: Any, options: CsvOptions | None = None, **changes: Any) -> list[Recording]:
    """Normalise the accepted inputs of :func:`~core.diagnosis.diagnose` to recordings.

    Files are read by :func:`core.csvio.read_csv` (the reader ``hyst fit`` uses: delimiter,
    decimal mark, header, units, time / input / output / run columns detected or chosen);
    a run or loop column gives one recording per run.

    Parameters
    ----------
    data : Recording, (t, u, y) tuple, CSV path, object with ``t``, ``u``, ``y``, or a list
        The recordings.
    options : CsvOptions, optional
        How CSV files are read (columns ``time``, ``input``, ``output``, ``run``, ...; see
        :class:`core.csvio.CsvOptions`); ``uneven`` is set by ``resample``.
    **changes
        Fields of :class:`~core.csvio.CsvOptions` replacing those of ``options``. Its
        ``resample`` (bool or float) applies to every recording: ``True`` puts uneven
        recordings (gaps included) on a uniform grid at their median spacing; a float
        resamples every recording to that spacing (s). By default small time-stamp jitter
        (every spacing below ``GAP_FACTOR`` times the median) is resampled with a cleaning
        note and a larger gap is an error that says where it is.

    Returns
    -------
    list of Recording
        Uniformly sampled (or without a time axis), at least 20 samples each.

    Raises
    ------
    ParameterError
        Unreadable files, too few samples, or a gap in the time stamps.
    """
    opts = CsvOptions.of(options, **changes)
    resample = opts.resample
    if isinstance(data, Recording | str | Path) or _is_triplet(data) or hasattr(data, "u"):
        data = [data]
    if not isinstance(data, Sequence) or len(data) == 0:
        raise ParameterError("diagnose needs at least one recording (t, u, y)")
    out: list[Recording] = []
    for i, d in enumerate(data):
        if isinstance(d, str | Path):
            p = Path(d)
            if not p.is_file():
                raise ParameterError(f"recording file {str(p)!r} does not exist")
            got = read_csv(p, opts, uneven="keep" if resample is False else "error")
        elif isinstance(d, Recording):
            got = [d.resampled(float(resample)) if _is_float(resample) and d.has_time else d]
        elif hasattr(d, "u") and hasattr(d, "y") and hasattr(d, "t"):
            got = [Recording(d.t, d.u, d.y, str(getattr(d, "name", f"recording{i + 1}")))]
        elif _is_triplet(d):
            got = [Recording(d[0], d[1], d[2], f"recording{i + 1}")]
        else:
            raise ParameterError(
                f"recording {i} is a {type(d).__name__}; pass (t, u, y) arrays, a Recording "
                "or a CSV path"
            )
        out.extend(_uniform(r, resample) for r in got)
    return out


def _is_float(x: Any) -> bool:
    return isinstance(x, float | int) and not isinstance(x, bool)


def _uniform(r: Recording, resample: bool | float) -> Recording:
    """``r`` on a uniform time grid: jitter resampled with a note, a gap an error."""
    if r.n_samples < MIN_SAMPLES:
        raise ParameterError(
            f"recording {r.name!r} has {r.n_samples} samples; the diagnosis needs at least "
            f"{MIN_SAMPLES}"
        )
    if not r.has_time or r.is_uniform:
        return r
    d = np.diff(r.t)
    med = float(np.median(d))
    j = int(np.argmax(d))
    if d[j] > GAP_FACTOR * med and resample is False:
        raise TimeGapError(r.name, float(d[j]), med, float(r.t[j]), float(r.t[j + 1]),
                           int(r.lines[j + 1]) if r.lines is not None else None)
    rr = r.resampled()
    note = (f"time-stamp jitter (spacing {d.min():.6g} to {d.max():.6g} s) resampled onto the "
            f"median spacing {med:.6g} s for the diagnosis")
    return replace(rr, cleaning=rr.cleaning[:-1] + (note,))


def _is_triplet(d: Any) -> bool:
    return isinstance(d, tuple | list) and len(d) == 3 and all(
        np.ndim(x) == 1 and np.size(x) > 3 for x in d
    )


def split_masks(
    records: Sequence[Recording],
    train: tuple[float, float] | None = None,
    test: tuple[float, float] | None = None,
    n_blocks: int = SPLIT_BLOCKS,
    min_block_s: float = MIN_BLOCK_S,
) -> tuple[list[np.ndarray], list[np.ndarray], str]:
    """Boolean train/test masks per recording.

    With explicit ``train``/``test`` time ranges ``(t0, t1)`` (seconds, half-open) they are
    applied to every recording; ``train`` alone leaves no test rows (the diagnosis then
    selects and scores by cross-fitting the training rows). Otherwise each recording is cut
    into ``n_blocks`` interleaved blocks (at least ``min_block_s`` long), alternating
    train/test, starting with train.

    Returns
    -------
    train_masks, test_masks : list of ndarray of bool
    description : str
    """
    trm, tem = [], []
    if train is not None or test is not None:
        if train is None:
            raise ParameterError("--test T0:T1 needs --train T0:T1 too (the rows to fit on)")
        for r in records:
            trm.append((r.t >= train[0]) & (r.t < train[1]))
            tem.append((r.t >= test[0]) & (r.t <= test[1]) if test is not None
                       else np.zeros(r.n_samples, dtype=bool))
        if sum(int(m.sum()) for m in trm) < MIN_WINDOW_TRAIN_ROWS or (
                test is not None and sum(int(m.sum()) for m in tem) < MIN_WINDOW_TEST_ROWS):
            raise ParameterError(
                f"train {train} / test {test} select too few samples; the recordings span "
                + ", ".join(f"{r.t[0]:g}..{r.t[-1]:g} s" for r in records)
            )
        desc = f"train t in [{train[0]:g}, {train[1]:g}) s, " + (
            f"test t in [{test[0]:g}, {test[1]:g}] s" if test is not None else "no test window")
        return trm, tem, desc
    for r in records:
        dur = r.t[-1] - r.t[0]
        nb = int(max(2, min(n_blocks, dur // min_block_s)))
        idx = np.minimum((np.arange(r.n_samples) * nb) // r.n_samples, nb - 1)
        trm.append(idx % 2 == 0)
        tem.append(idx % 2 == 1)
    desc = f"interleaved blocks ({n_blocks} per recording, alternating train/test)"
    return trm, tem, desc


def crossfit_folds(
    records: Sequence[Recording],
    train: Sequence[np.ndarray],
    min_block_s: float = MIN_BLOCK_S,
    max_blocks: int = MAX_FOLDS,
) -> list[tuple[list[np.ndarray], list[np.ndarray]]]:
    """Blocked cross-validation folds over the training rows (after the wipe-out time).

    The training rows of each recording that come after its wipe-out time
    (:func:`wipeout_index`) are cut into contiguous blocks of at least ``min_block_s``
    seconds (at most ``max_blocks`` in all); each fold holds one block out. Rows before the
    wipe-out time are kept in every fold's training rows: their prediction depends on the
    unknown initial memory state, which is judged separately.

    Parameters
    ----------
    records : sequence of Recording
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
            blocks = [np.zeros(r.n_samples, dtype=bool) for r in records]
            blocks[k][idx[edges[i] : edges[i + 1]]] = True
            folds.append(([m & ~b for m, b in zip(train, blocks, strict=True)], blocks))
    return folds if len(folds) >= 2 else []
