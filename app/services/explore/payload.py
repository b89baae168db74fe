"""The JSON body of a simulation's figures (``/api/simulate`` and a session's figure
endpoints): a :class:`~app.services.explore.simulation.Result` in, plain JSON out (no web
imports).

It lives beside the figures, below the session's actions and the jobs' tasks: the tasks run
it in a worker process (:func:`app.services.jobs.tasks.run_figures`), the actions price and
start those tasks, so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any, NotRequired, TypedDict

from app.services.explore import figures as F
from app.services.explore.simulation import Result, operator_count, pi_part, weight_note
from app.services.words import model_words

__all__ = ["FiguresBody", "result_payload"]


class FiguresBody(TypedDict):
    """The JSON body of a simulation's figures (:func:`result_payload`), in its key order."""

    model_type: str
    #: the model in words, and what a negative play weight does (or None)
    model_title: str
    model_note: str | None
    n_operators: int | None
    #: why the inverse could not be drawn, when it could not
    inverse_error: str | None
    #: each figure asked for, by name: plotly's JSON of it
    figures: dict[str, dict[str, Any]]
    elapsed_ms: float
    version: int
    #: rows of the digitized trace (the step and play range), when it was computed
    digitized_states: NotRequired[int]
    #: of a model with a classical PI part: its slopes, widest loop and invertibility
    slopes: NotRequired[list[float]]
    max_loop_width: NotRequired[float]
    invertible: NotRequired[bool]
    #: ``include_data``: the samples ``t``, ``u``, ``y``
    data: NotRequired[dict[str, list[float]]]


def result_payload(res: Result, names: Collection[str],
                   include_data: bool = False, state: int | None = None) -> FiguresBody:
    """The JSON body of ``/api/simulate`` and the session figure endpoints; ``state``
    highlights that row of the digitized trace (the web page's step and play), and
    ``digitized_states`` says how many rows it has."""
    m = res.model
    figs = {n: (F.digitized_figure(res, highlight=state) if n == "digitized" and
                state is not None and "digitized" in res.views else F.build(n, res)).to_dict()
            for n in names}
    out: FiguresBody = {
        "model_type": m.type_name,
        "model_title": model_words(m),
        "model_note": weight_note(m),
        "n_operators": operator_count(m),
        "inverse_error": res.inverse_error,
        "figures": figs,
        "elapsed_ms": res.elapsed_ms,
        "version": res.version,
    }
    if res.digitized is not None:
        out["digitized_states"] = len(res.digitized.trace.sample)
    pi = pi_part(m)
    if pi is not None:
        out["slopes"] = pi.slopes.tolist()
        out["max_loop_width"] = pi.max_loop_width
        out["invertible"] = pi.is_invertible
    if include_data:
        out["data"] = {"t": res.t.tolist(), "u": res.u.tolist(), "y": res.y.tolist()}
    return out
