"""A sensor zero that differs between recordings (one offset per recording)."""

from __future__ import annotations

from ...effects import Offset
from ..candidates import Candidate
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..structure import Fit


def _untestable(ctx: FitContext) -> str | None:
    """An offset per recording needs several recordings."""
    if len(ctx.records) < 2:
        return "with one recording a sensor offset is absorbed exactly by the model's bias"
    return None


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """One offset per recording (needs >= 2 recordings)."""
    s = cur.structure
    if s.offsets or len(ctx.records) < 2:
        return None
    fit = ctx.fit(s.with_(offsets=True), cur)
    return fit, {"offsets": fit.bias.tolist()}, {}


register(DiagnosableEffect(
    "offset",
    family="static-offset",
    explanation='The sensor zero differs between recordings (an offset per recording).',
    equation='y = x + c_k  (one offset per recording)',
    experiment='several recordings (an offset per recording), or an independent zero reference',
    lookalikes=("drift",),
    build=_build,
    model_type=Offset,
    structure_field="offsets",
    untestable=_untestable,
    linear=True,
    stage_order=5,
))
