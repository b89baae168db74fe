"""A sensor zero that differs between recordings (one offset per recording)."""

from __future__ import annotations

import numpy as np

from ...stages import Offset
from ..candidates import Candidate
from ..context import FitContext
from ..registry import DiagnosableEffect, StaticTerm, TermRows, register
from ..structure import Fit


def _columns(per_recording: bool, rows: TermRows) -> np.ndarray:
    """A constant: one common bias column, or one per recording (its own, the others 0)."""
    out = np.zeros((rows.rows.size, rows.fit.n_records if per_recording else 1))
    out[:, rows.k if per_recording else 0] = 1.0
    return out


def _unseen(per_recording: bool, bias: np.ndarray, j: int) -> np.ndarray:
    """An unseen recording's own offset is unknown: the mean of the others'."""
    bias = np.array(bias, dtype=float)
    if per_recording:
        bias[j] = float(np.mean(np.delete(bias, j)))
    return bias


#: Switched off, the term is the model's one common bias (a column and a stage still).
TERM = StaticTerm(
    off=False,
    width=lambda per_recording, n_records: n_records if per_recording else 1,
    columns=_columns,
    coefficients=lambda per_recording, w, fit: w,
    stage=lambda per_recording, bias, k, record: Offset(float(bias[k] if per_recording
                                                              else bias[0])),
    per_recording=True,
    level_degree=lambda per_recording: 0,
    unseen=_unseen,
)


def _untestable(ctx: FitContext) -> str | None:
    """An offset per recording needs several recordings."""
    if len(ctx.records) < 2:
        return "with one recording a sensor offset is absorbed exactly by the model's bias"
    return None


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """One offset per recording (needs >= 2 recordings)."""
    s = cur.structure
    if s.term("offset") or len(ctx.records) < 2:
        return None
    fit = ctx.fit(s.with_term("offset", True), cur)
    return fit, {"offsets": fit.terms["offset"].tolist()}, {}


register(DiagnosableEffect(
    "offset",
    family="static-offset",
    explanation='The sensor zero differs between recordings (an offset per recording).',
    parameter_words=(("offsets", "offset of each recording", "output"),),
    equation='y = x + c_k  (one offset per recording)',
    experiment='several recordings (an offset per recording), or an independent zero reference',
    lookalikes=("drift",),
    build=_build,
    model_type=Offset,
    structure_field="terms",
    term=TERM,
    untestable=_untestable,
    linear=True,
    stage_order=5,
    deciding=(
        ("drift", "a zero-input hold at the start and the end of every "
         "recording (an offset stays the same within a recording, a drift moves it)"),
    ),
))
