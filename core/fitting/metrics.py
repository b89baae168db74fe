"""Honest fit metrics: :class:`FitReport` and the streaming pass that computes it.

Every regressor in :mod:`core.fitting` fills a :class:`FitReport` after the fit with one
extra pass over the data (chunked, so memory does not grow with the record length):

* modelling errors on the training and held-out samples: RMSE, max abs error and RMSE as a
  percentage of the output range (max − min of the *measured* output on that part);
* the **compensation error** ``M(M⁻¹(y_d)) − y_d`` with ``y_d`` the measured output: the
  fitted model driven by its own exact inverse; it is at round-off level (~1e-12 relative)
  exactly when the fitted model is invertible, so it proves invertibility on the data;
* the **inverse input error** ``M⁻¹(y) − u``: the command the inverse (a feedforward
  compensator) would issue to obtain the measured output, compared with the input that
  really produced it, in input units. It combines modelling error, measurement noise and the
  inverse's sensitivity (slope ``1/p0`` right after every reversal), so it is the number that
  predicts open-loop compensation quality, not the forward RMSE alone.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .._typing import Float1D
from ..base import Model
from .gram import Segment

__all__ = ["FitReport", "PartStats", "evaluate_fit", "percent_of_range"]

#: Samples per chunk of the evaluation pass.
EVAL_CHUNK = 65536


@dataclass(frozen=True)
class PartStats:
    """Error statistics on one part of the data (training or held-out).

    Attributes
    ----------
    n_samples : int
        Number of samples in the part.
    rmse : float
        Root-mean-square modelling error (output units).
    max_abs : float
        Largest absolute modelling error (output units).
    output_range : float
        ``max(y) - min(y)`` of the measured output on the part (output units).
    rmse_pct : float
        ``100 * rmse / output_range`` (%).
    inverse_input_rmse : float
        RMSE of ``M⁻¹(y) - u`` (input units), see the module docstring.
    input_range : float
        ``max(u) - min(u)`` on the part (input units).
    inverse_input_rmse_pct : float
        ``100 * inverse_input_rmse / input_range`` (%).
    """

    n_samples: int
    rmse: float
    max_abs: float
    output_range: float
    rmse_pct: float
    inverse_input_rmse: float
    input_range: float
    inverse_input_rmse_pct: float


@dataclass(frozen=True)
class FitReport:
    """Summary of a fit (frozen; ``to_dict()`` gives plain JSON-ready values).

    Attributes
    ----------
    model_type : str
        ``type_name`` of the fitted model.
    n_parameters : int
        Number of fitted parameters (weights, offset, memoryless parameters).
    train : PartStats
        Errors on the samples the parameters were fitted to.
    test : PartStats or None
        Errors on held-out samples (``None`` when nothing was held out).
    compensation_max_abs : float
        ``max |M(M⁻¹(y)) - y|`` over all evaluated samples (output units); ~1e-12 relative
        for an invertible model.
    compensation_rmse : float
        RMSE of the same quantity.
    invertible : bool
        Whether the fitted model's inverse exists (all slopes positive).
    min_slope : float
        Smallest loop-segment slope of the hysteresis part (output per input unit).
    condition_number : float
        Condition number of the column-scaled Gram matrix of the final linear solve.
    solver : str
        How the linear weights were obtained (``"gram-cholesky-nnls"``, ``"tsqr-nnls"``...).
    extra : dict
        Model-specific numbers (selected ``n``, cross-validation scores, discretisation
        error, envelope parameters, the loops' orientation, ...).
    warnings : tuple of str
        What the user must know about the fit, in words: the warnings the fit raised and,
        when the held-out RMSE is above 5 noise floors, that the model misses structure
        and where (:func:`core.fitting.adequacy.misfit`; added by
        :func:`core.fitting.fit_recordings`).
    """

    model_type: str
    n_parameters: int
    train: PartStats
    test: PartStats | None
    compensation_max_abs: float
    compensation_rmse: float
    invertible: bool
    min_slope: float
    condition_number: float
    solver: str
    extra: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (nested ``train``/``test`` dictionaries, floats, lists)."""
        d = asdict(self)
        d["extra"] = _jsonable(dict(self.extra))
        d["warnings"] = list(self.warnings)
        return d

    def summary(self) -> str:
        """One-paragraph human-readable summary."""
        lines = [
            f"{self.model_type}: {self.n_parameters} parameters, solver {self.solver}, "
            f"cond {self.condition_number:.3g}",
            f"  train: RMSE {self.train.rmse:.4g} ({self.train.rmse_pct:.3f} % of range "
            f"{self.train.output_range:.4g}), max |e| {self.train.max_abs:.4g}, "
            f"n = {self.train.n_samples}",
        ]
        if self.test is not None:
            lines.append(
                f"  test:  RMSE {self.test.rmse:.4g} ({self.test.rmse_pct:.3f} % of range "
                f"{self.test.output_range:.4g}), max |e| {self.test.max_abs:.4g}, "
                f"n = {self.test.n_samples}"
            )
        cv = self.extra.get("cv_choice")
        if isinstance(cv, str):
            lines.append(f"  {cv}")
        mem = self.extra.get("initial_memory")
        if isinstance(mem, dict) and (mem.get("excluded_train_rows")
                                      or any(mem.get("steady_state") or ())):
            lines.append(f"  {mem['summary']}")
        for key in ("base_choice", "orientation", "branch"):
            note = self.extra.get(key)
            if isinstance(note, str):
                lines.append(f"  {note}")
        part = self.test if self.test is not None else self.train
        lines.append(
            f"  inverse: invertible={self.invertible}, min slope {self.min_slope:.4g}, "
            f"compensation max |e| {self.compensation_max_abs:.3g}, inverse input RMSE "
            f"{part.inverse_input_rmse:.4g} ({part.inverse_input_rmse_pct:.3f} % of input range)"
        )
        lines.extend(f"  warning: {w}" for w in self.warnings)
        return "\n".join(lines)


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x


def percent_of_range(rmse: float, ys: Sequence[Float1D]) -> float:
    """``100 * rmse / (max - min)`` of the measured outputs ``ys`` of the scored rows.

    The one definition of "% of range" (fit reports, the diagnosis): the range of the rows
    the RMSE is computed on, over every recording pooled. ``inf`` for a constant output.
    """
    lo = min((float(np.min(y)) for y in ys if np.size(y)), default=np.inf)
    hi = max((float(np.max(y)) for y in ys if np.size(y)), default=-np.inf)
    return 100.0 * rmse / (hi - lo) if hi > lo else float("inf")


class _Acc:
    """Running sums for one label."""

    def __init__(self) -> None:
        self.n = 0
        self.sse = 0.0
        self.max_abs = 0.0
        self.ymin = np.inf
        self.ymax = -np.inf
        self.umin = np.inf
        self.umax = -np.inf
        self.inv_sse = 0.0

    def add(self, u: Float1D, y: Float1D, e: Float1D, ui: Float1D) -> None:
        if u.size == 0:
            return
        self.n += u.size
        self.sse += float(e @ e)
        self.max_abs = max(self.max_abs, float(np.max(np.abs(e))))
        self.ymin = min(self.ymin, float(y.min()))
        self.ymax = max(self.ymax, float(y.max()))
        self.umin = min(self.umin, float(u.min()))
        self.umax = max(self.umax, float(u.max()))
        d = ui - u
        self.inv_sse += float(d @ d)

    def stats(self) -> PartStats | None:
        if self.n == 0:
            return None
        rmse = float(np.sqrt(self.sse / self.n))
        yr = self.ymax - self.ymin
        ur = self.umax - self.umin
        irmse = float(np.sqrt(self.inv_sse / self.n))
        return PartStats(
            n_samples=self.n,
            rmse=rmse,
            max_abs=self.max_abs,
            output_range=yr,
            rmse_pct=100.0 * rmse / yr if yr > 0 else float("inf"),
            inverse_input_rmse=irmse,
            input_range=ur,
            inverse_input_rmse_pct=100.0 * irmse / ur if ur > 0 else float("inf"),
        )


def evaluate_fit(
    model_for: Callable[[Float1D], Model],
    offset: float,
    segments: Sequence[Segment],
    *,
    train_labels: Sequence[int],
    test_labels: Sequence[int] = (),
    invertible: bool = True,
    chunk: int = EVAL_CHUNK,
    compensation: bool = True,
) -> tuple[PartStats, PartStats | None, float, float]:
    """One streaming pass: modelling errors, compensation and inverse-input errors.

    Parameters
    ----------
    model_for : callable
        ``model_for(u)`` returns the fitted model (without the output offset) whose default
        state is the one used for a recording with input ``u`` (only ``u[0]`` matters for
        the built-in rules).
    offset : float
        Output offset added to the model output (output units).
    segments : sequence of Segment
        Recordings with labels (``-1`` samples are simulated but not scored).
    train_labels, test_labels : sequence of int
        Labels that belong to the training / held-out part.
    invertible : bool
        Whether to run the inverse (compensation and inverse-input errors are NaN if not).
    chunk : int
        Samples per chunk.
    compensation : bool
        With ``invertible``, also run the inverse (compensation and inverse-input errors);
        ``False`` only forms it (a model without an inverse raises as with ``True``) and
        leaves those errors NaN.

    Returns
    -------
    train : PartStats
    test : PartStats or None
    compensation_max_abs, compensation_rmse : float
    """
    acc_tr, acc_te = _Acc(), _Acc()
    comp_max = 0.0
    comp_sse = 0.0
    comp_n = 0
    tr = np.asarray(list(train_labels))
    te = np.asarray(list(test_labels))
    for seg in segments:
        model = model_for(seg.u)
        inv = model.inverse() if invertible else None
        if not compensation:
            inv = None
        st = st_inv = st_fw = None
        for s0 in range(0, seg.u.size, chunk):
            s1 = min(seg.u.size, s0 + chunk)
            uc, yc = seg.u[s0:s1], seg.y[s0:s1]
            r = model.simulate(uc, state=st)
            st = r.state
            e = r.y + offset - yc
            if inv is not None:
                ri = inv.simulate(yc - offset, state=st_inv)
                st_inv = ri.state
                rf = model.simulate(ri.y, state=st_fw)
                st_fw = rf.state
                ui = ri.y
                ce = rf.y + offset - yc
            else:
                ui = np.full(uc.size, np.nan)
                ce = None
            lab = seg.labels[s0:s1] if seg.labels is not None else np.zeros(uc.size, np.int8)
            m_tr = np.isin(lab, tr)
            m_te = np.isin(lab, te) if te.size else np.zeros(uc.size, dtype=bool)
            acc_tr.add(uc[m_tr], yc[m_tr], e[m_tr], ui[m_tr])
            acc_te.add(uc[m_te], yc[m_te], e[m_te], ui[m_te])
            if ce is not None:
                sel = m_tr | m_te
                if sel.any():
                    cs = ce[sel]
                    comp_max = max(comp_max, float(np.max(np.abs(cs))))
                    comp_sse += float(cs @ cs)
                    comp_n += int(sel.sum())
    train = acc_tr.stats()
    if train is None:  # pragma: no cover - guarded by the regressors
        raise ValueError("no training samples to evaluate")
    if not (invertible and compensation):
        comp_max = comp_rmse = float("nan")
    else:
        comp_rmse = float(np.sqrt(comp_sse / comp_n)) if comp_n else float("nan")
    return train, acc_te.stats(), comp_max, comp_rmse
