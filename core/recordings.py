"""Measured recordings: one input, one output, a time axis, and an honest cleaning log.

A :class:`Recording` is the value object every reader in this package returns
(:func:`core.csvio.read_csv`, :func:`core.datasets.load_dataset`). It keeps the samples
together with what is needed to trust them later: units, the source columns, the
provenance (file path, run id, citation) and a human-readable list of everything that was
done to the raw data (rows removed, units converted, resampling, windows).

Time is always in seconds. Recordings without a time axis (quasi-static loops such as
B-H curves) use the sample index as ``t`` and set ``has_time=False``; their ``dt`` is then
one "sample" and :meth:`Recording.resampled` refuses to run.
"""

from __future__ import annotations

import csv
import functools
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, Literal

import numpy as np

from ._typing import Float1D
from .exceptions import ParameterError
from .validation import as_finite_scalar, frozen

__all__ = ["Recording", "UNIFORM_RTOL"]

#: Relative tolerance of :attr:`Recording.is_uniform`: every spacing within 1 % of ``dt``.
UNIFORM_RTOL = 1e-2

_ROLES = ("time", "input", "output")


def _readonly(a: Any) -> np.ndarray:
    """Read-only copy of ``a``; float64 when numeric, otherwise as given (text channels)."""
    arr = np.asarray(a)
    if arr.dtype.kind in "biuf":
        arr = np.array(arr, dtype=np.float64)
    else:
        arr = np.array(arr)
    arr.flags.writeable = False
    return arr


def _fmt_t(x: float) -> str:
    return f"{x:.10g}"


@dataclass(frozen=True, eq=False)
class Recording:
    """One measured input/output record on a common time axis.

    Parameters
    ----------
    t : array_like of shape (N,)
        Sample times in seconds, strictly increasing. For recordings without a time axis
        (``has_time=False``) the sample index ``0, 1, ...`` of the source rows.
    u : array_like of shape (N,)
        Input samples (finite), in ``units["input"]``.
    y : array_like of shape (N,)
        Output samples (finite), in ``units["output"]``.
    name : str
        Short human-readable name (file stem, dataset name, run).
    units : mapping
        Units of the ``"time"``, ``"input"`` and ``"output"`` axes, e.g.
        ``{"time": "s", "input": "V", "output": "µm"}``; missing keys become ``""``
        (``"time"`` defaults to ``"s"``, or ``"sample"`` without a time axis).
    columns : mapping
        Source column names of the roles ``"time"``, ``"input"``, ``"output"`` (and
        ``"run"`` when a run column split the file).
    extra : mapping of str to ndarray of shape (N,)
        Other channels of the source, kept sample-aligned (float64, or text when the column
        was not numeric). Never used by the models, never dropped.
    extra_units : mapping of str to str
        Units of the ``extra`` channels.
    source : str
        Provenance: file path, or ``"<text>"``/``"<bytes>"``, or a dataset name.
    run : str or int, optional
        Run / record / loop id when one file holds several recordings.
    cleaning : tuple of str
        Human-readable notes about everything done to the raw data (removed rows with
        their line numbers, unit conversions, resampling, windows). Empty when the data is
        exactly as measured.
    has_time : bool
        False when the source had no time column and ``t`` is the sample index.
    citation : str
        Attribution / citation of the data (shipped datasets always fill it).
    lines : array_like of int, shape (N,), optional
        1-based source line of each sample, for tracing problems back to the file.

    Raises
    ------
    ParameterError
        If the arrays are not one-dimensional with the same length, hold NaN/inf, or
        ``t`` does not strictly increase.

    Examples
    --------
    >>> r = Recording([0.0, 0.1, 0.2, 0.3], [0.0, 1.0, 0.0, -1.0], [0.0, 0.8, 0.3, -0.7])
    >>> r.fs, r.n_samples, r.duration
    (10.0, 4, 0.3)
    """

    t: Float1D
    u: Float1D
    y: Float1D
    name: str = "recording"
    units: Mapping[str, str] = field(default_factory=dict)
    columns: Mapping[str, str] = field(default_factory=dict)
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)
    extra_units: Mapping[str, str] = field(default_factory=dict)
    source: str = ""
    run: str | int | None = None
    cleaning: tuple[str, ...] = ()
    has_time: bool = True
    citation: str = ""
    lines: np.ndarray | None = None

    def __post_init__(self) -> None:
        arrays = {}
        for key in ("t", "u", "y"):
            try:
                a = np.asarray(getattr(self, key), dtype=np.float64)
            except (TypeError, ValueError) as exc:
                raise ParameterError(f"Recording.{key} must be numeric: {exc}") from exc
            if a.ndim != 1:
                raise ParameterError(
                    f"Recording.{key} must be one-dimensional (shape (N,)), got shape {a.shape}"
                )
            arrays[key] = a
        n = arrays["t"].size
        if n == 0:
            raise ParameterError(f"recording {self.name!r} has no samples")
        for key in ("u", "y"):
            if arrays[key].size != n:
                raise ParameterError(
                    f"Recording.{key} has {arrays[key].size} samples but t has {n}; "
                    "t, u and y must have the same length"
                )
        for key in ("t", "u", "y"):
            bad = ~np.isfinite(arrays[key])
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise ParameterError(
                    f"Recording.{key}[{i}] = {arrays[key][i]} is not finite; remove or "
                    "interpolate NaN/inf samples first (read_csv does it and reports it)"
                )
        d = np.diff(arrays["t"])
        if (d <= 0).any():
            i = int(np.flatnonzero(d <= 0)[0])
            raise ParameterError(
                f"Recording.t must strictly increase, but t[{i + 1}] = {arrays['t'][i + 1]:g} "
                f"<= t[{i}] = {arrays['t'][i]:g}; sort the samples and remove duplicates"
            )
        for key, a in arrays.items():
            object.__setattr__(self, key, frozen(a))
        units = {"time": "s" if self.has_time else "sample", "input": "", "output": ""}
        units.update({k: str(v) for k, v in dict(self.units).items()})
        object.__setattr__(self, "units", MappingProxyType(units))
        object.__setattr__(self, "columns", MappingProxyType(dict(self.columns)))
        extra = {}
        for k, v in dict(self.extra).items():
            a = _readonly(v)
            if a.shape != (n,):
                raise ParameterError(
                    f"extra channel {k!r} has shape {a.shape}, expected ({n},) like t"
                )
            extra[str(k)] = a
        object.__setattr__(self, "extra", MappingProxyType(extra))
        object.__setattr__(
            self, "extra_units", MappingProxyType({str(k): str(v) for k, v in
                                                   dict(self.extra_units).items()})
        )
        object.__setattr__(self, "cleaning", tuple(str(c) for c in self.cleaning))
        if self.lines is not None:
            li = np.array(self.lines, dtype=np.int64)
            if li.shape != (n,):
                raise ParameterError(f"lines has shape {li.shape}, expected ({n},) like t")
            li.flags.writeable = False
            object.__setattr__(self, "lines", li)

    def __reduce__(self) -> tuple[Any, tuple[dict[str, Any]]]:
        """Pickle / deepcopy support (the read-only mappings are stored as plain dicts)."""
        state = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, MappingProxyType):
                v = dict(v)
            state[f.name] = v
        return (_rebuild, (state,))

    # ------------------------------------------------------------------ properties
    @property
    def n_samples(self) -> int:
        """Number of samples ``N``."""
        return int(self.t.size)

    @property
    def dt(self) -> float:
        """Sample spacing in seconds (samples without a time axis).

        The mean spacing ``(t[-1] - t[0]) / (N - 1)`` when the record is uniform (exact
        even when the printed time stamps were rounded), otherwise the median spacing.

        Raises
        ------
        ParameterError
            If the recording has a single sample.
        """
        if self.n_samples < 2:
            raise ParameterError(f"recording {self.name!r} has one sample: no sample spacing")
        if self.is_uniform:
            return float((self.t[-1] - self.t[0]) / (self.n_samples - 1))
        return float(np.median(np.diff(self.t)))

    @property
    def fs(self) -> float:
        """Sampling rate ``1 / dt`` in Hz (per sample without a time axis)."""
        return 1.0 / self.dt

    @property
    def duration(self) -> float:
        """Time span ``t[-1] - t[0]`` in seconds."""
        return float(self.t[-1] - self.t[0])

    @functools.cached_property
    def is_uniform(self) -> bool:
        """Whether every spacing is within :data:`UNIFORM_RTOL` (1 %) of the mean spacing
        (computed once: the time axis is read-only)."""
        if self.n_samples < 3:
            return True
        d = np.diff(self.t)
        mean = (self.t[-1] - self.t[0]) / (self.n_samples - 1)
        return bool(np.max(np.abs(d - mean)) <= UNIFORM_RTOL * mean)

    def _with(self, note: str | None, keep: np.ndarray | slice, **changes: Any) -> Recording:
        """Copy with the samples ``keep`` and an extra cleaning note."""
        kw: dict[str, Any] = {
            "t": self.t[keep],
            "u": self.u[keep],
            "y": self.y[keep],
            "extra": {k: v[keep] for k, v in self.extra.items()},
            "lines": None if self.lines is None else self.lines[keep],
            "cleaning": self.cleaning + ((note,) if note else ()),
        }
        kw.update(changes)
        return replace(self, **kw)

    # ------------------------------------------------------------------ windows
    def mask(
        self,
        t_start: float | None = None,
        t_end: float | None = None,
        *,
        closed: Literal["left", "both"] = "left",
    ) -> np.ndarray:
        """Boolean mask of the samples with ``t_start <= t < t_end`` (``<= t_end`` if closed).

        Parameters
        ----------
        t_start, t_end : float, optional
            Window limits in seconds (sample indices without a time axis); open-ended when
            omitted.
        closed : {"left", "both"}
            ``"left"``: half-open ``[t_start, t_end)`` (adjacent windows never share a
            sample); ``"both"``: closed ``[t_start, t_end]``.

        Returns
        -------
        ndarray of bool, shape (N,)
        """
        if closed not in ("left", "both"):
            raise ParameterError(f"closed must be 'left' or 'both', got {closed!r}")
        lo = -np.inf if t_start is None else as_finite_scalar(t_start, "t_start")
        hi = np.inf if t_end is None else as_finite_scalar(t_end, "t_end")
        if hi < lo or (hi == lo and closed == "left"):
            raise ParameterError(
                f"empty window: t_start = {lo:g} must be < t_end = {hi:g}"
            )
        m = self.t >= lo
        m &= (self.t <= hi) if closed == "both" else (self.t < hi)
        return m

    def window(
        self,
        t_start: float | None = None,
        t_end: float | None = None,
        *,
        closed: Literal["left", "both"] = "left",
    ) -> Recording:
        """The samples in a time window, as a new recording (times are not shifted).

        Parameters
        ----------
        t_start, t_end : float, optional
            Limits in seconds (see :meth:`mask`); e.g. train ``window(3.3, 7.0)`` and test
            ``window(7.0, 9.0, closed="both")``.
        closed : {"left", "both"}
            Half-open ``[t_start, t_end)`` (default) or closed ``[t_start, t_end]``.

        Returns
        -------
        Recording
            With a cleaning note naming the window.

        Raises
        ------
        ParameterError
            If the window holds no sample (the message gives the recording's span).
        """
        m = self.mask(t_start, t_end, closed=closed)
        lo = "-inf" if t_start is None else _fmt_t(float(t_start))
        hi = "inf" if t_end is None else _fmt_t(float(t_end))
        br = "]" if closed == "both" else ")"
        unit = self.units["time"]
        if not m.any():
            raise ParameterError(
                f"window t ∈ [{lo}, {hi}{br} {unit} of recording {self.name!r} holds no "
                f"sample; the recording spans [{_fmt_t(self.t[0])}, {_fmt_t(self.t[-1])}] {unit}"
            )
        note = f"window t ∈ [{lo}, {hi}{br} {unit}: kept {int(m.sum())} of {self.n_samples} samples"
        return self._with(note, m, name=f"{self.name} [{lo}, {hi}{br}")

    def split_at(self, t_split: float) -> tuple[Recording, Recording]:
        """Split into ``t < t_split`` and ``t >= t_split`` (e.g. train / held-out).

        Returns
        -------
        before, after : Recording
        """
        return self.window(None, t_split), self.window(t_split, None, closed="both")

    def split_blocks(self, k: int) -> list[Recording]:
        """Cut into ``k`` contiguous blocks of (nearly) equal sample count.

        Use them for blocked cross-validation: fit on all blocks but one and score on the
        held-out block. Block ``j`` gets the cleaning note ``"block j+1 of k ..."``.

        Parameters
        ----------
        k : int
            Number of blocks, ``1 <= k <= N // 2`` (each block needs two samples).

        Returns
        -------
        list of Recording
            ``k`` recordings in time order; their samples partition this recording.
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise ParameterError(f"k must be an integer number of blocks, got {k!r}")
        k = int(k)
        if k < 1 or k > self.n_samples // 2:
            raise ParameterError(
                f"k = {k} blocks is not possible for {self.n_samples} samples; "
                f"use 1 <= k <= {self.n_samples // 2} (at least two samples per block)"
            )
        edges = np.linspace(0, self.n_samples, k + 1).round().astype(int)
        out = []
        for j in range(k):
            a, b = int(edges[j]), int(edges[j + 1])
            note = (
                f"block {j + 1} of {k}: samples {a}..{b - 1}, "
                f"t ∈ [{_fmt_t(self.t[a])}, {_fmt_t(self.t[b - 1])}] {self.units['time']}"
            )
            out.append(self._with(note, slice(a, b), name=f"{self.name} block {j + 1}/{k}"))
        return out

    # ------------------------------------------------------------------ resampling
    def resampled(self, dt: float | None = None) -> Recording:
        """Linear interpolation onto the uniform grid ``t[0], t[0] + dt, ... <= t[-1]``.

        Parameters
        ----------
        dt : float, optional
            New spacing in seconds; the median spacing of this recording by default.

        Returns
        -------
        Recording
            Numeric extra channels are interpolated too (text channels are dropped, which
            the cleaning note says); ``lines`` is dropped.

        Raises
        ------
        ParameterError
            Without a time axis (``has_time=False``), or if ``dt`` is not positive or
            would make more than 100 times as many samples.
        """
        if not self.has_time:
            raise ParameterError(
                f"recording {self.name!r} has no time axis (t is the sample index), so it "
                "cannot be resampled in time; give the sampling rate when reading (fs=...)"
            )
        if self.n_samples < 2:
            raise ParameterError(f"recording {self.name!r} has one sample: nothing to resample")
        old_dt = float(np.median(np.diff(self.t)))
        new_dt = old_dt if dt is None else as_finite_scalar(dt, "dt", positive=True)
        m = int(np.floor(self.duration / new_dt * (1 + 1e-12))) + 1
        if m > 100 * self.n_samples:
            raise ParameterError(
                f"dt = {new_dt:g} s would make {m} samples from {self.n_samples}; "
                "choose a larger dt"
            )
        t = self.t[0] + new_dt * np.arange(m)
        d = np.diff(self.t)
        extra, dropped = {}, []
        for k, v in self.extra.items():
            if v.dtype.kind == "f":
                extra[k] = np.interp(t, self.t, v)
            else:
                dropped.append(k)
        note = (
            f"resampled by linear interpolation from {self.n_samples} samples (spacing "
            f"{d.min():.6g} to {d.max():.6g} s) onto {m} samples at dt = {new_dt:.6g} s"
        )
        if dropped:
            note += f"; dropped text channel(s) {', '.join(dropped)}"
        return replace(
            self,
            t=t,
            u=np.interp(t, self.t, self.u),
            y=np.interp(t, self.t, self.y),
            extra=extra,
            extra_units={k: v for k, v in self.extra_units.items() if k in extra},
            lines=None,
            cleaning=self.cleaning + (note,),
        )

    # ------------------------------------------------------------------ output
    def column_header(self, role: str) -> str:
        """``name_unit`` header of a role (``"time"``, ``"input"``, ``"output"``) for CSV."""
        base = {"time": "t", "input": "u", "output": "y"}[role]
        unit = self.units.get(role, "")
        if role == "time" and not self.has_time:
            return "sample"
        return f"{base} [{unit}]" if unit else base

    def to_csv(self, path: str | os.PathLike[str], *, comments: bool = True) -> Path:
        """Write ``t, u, y`` and the numeric extra channels as comma-separated text.

        Without a time axis the first column is the sample index, named ``sample``.

        The header row carries the units (``t [s],u [V],y [µm],...``) and, with
        ``comments=True``, ``#`` lines before it record name, source, run, citation and
        cleaning notes; :func:`core.csvio.read_csv` skips them and reads the file back
        exactly (values are written with 17 significant digits).

        Parameters
        ----------
        path : path-like
            Destination file (overwritten).
        comments : bool
            Write the provenance comment lines.

        Returns
        -------
        pathlib.Path
        """
        p = Path(path)
        names = [self.column_header(r) for r in _ROLES]
        cols = [self.t, self.u, self.y]
        text_channels = []
        for k, v in self.extra.items():
            if v.dtype.kind == "f":
                unit = self.extra_units.get(k, "")
                names.append(f"{k} [{unit}]" if unit else k)
                cols.append(v)
            else:
                text_channels.append(k)
        data = np.column_stack(cols)
        with p.open("w", encoding="utf-8", newline="") as fh:
            if comments:
                fh.write(f"# name: {self.name}\n")
                if self.source:
                    fh.write(f"# source: {self.source}\n")
                if self.run is not None:
                    fh.write(f"# run: {self.run}\n")
                if self.citation:
                    fh.write(f"# citation: {' '.join(self.citation.split())}\n")
                for c in self.cleaning:
                    fh.write(f"# cleaning: {c}\n")
                if text_channels:
                    fh.write(f"# not written (text channels): {', '.join(text_channels)}\n")
            csv.writer(fh, lineterminator="\n").writerow(names)
            np.savetxt(fh, data, delimiter=",", fmt="%.17g")
        return p

    def __repr__(self) -> str:
        span = (
            f"{self.duration:g} s at {self.fs:g} Hz" if self.has_time and self.n_samples > 1
            else "no time axis"
        )
        run = "" if self.run is None else f", run={self.run!r}"
        return (
            f"Recording({self.name!r}, {self.n_samples} samples, {span}, "
            f"u [{self.units['input']}], y [{self.units['output']}]{run}, "
            f"{len(self.cleaning)} cleaning note(s))"
        )


def _rebuild(state: dict[str, Any]) -> Recording:
    """Inverse of :meth:`Recording.__reduce__`."""
    return Recording(**state)
