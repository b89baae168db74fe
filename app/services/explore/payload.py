"""The JSON body of a simulation's figures (``/api/simulate`` and a session's figure
endpoints): a :class:`~app.services.explore.simulation.Result` in, plain JSON out (no web
imports).

It lives beside the figures, below the session's actions and the jobs' tasks: the tasks run
it in a worker process (:func:`app.services.jobs.tasks.run_figures`), the actions price and
start those tasks, so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

from app.services.explore import figures as F
from app.services.explore.simulation import Result, operator_count, pi_part, weight_note
from app.services.words import model_words

__all__ = ["result_payload"]


def result_payload(res: Result, names: Collection[str],
                   include_data: bool = False, state: int | None = None) -> dict[str, Any]:
    """The JSON body of ``/api/simulate`` and the session figure endpoints; ``state``
    highlights that row of the digitized trace (the web page's step and play), and
    ``digitized_states`` says how many rows it has."""
    m = res.model
    figs = {n: (F.digitized_figure(res, highlight=state) if n == "digitized" and
                state is not None and "digitized" in res.views else F.build(n, res)).to_dict()
            for n in names}
    out: dict[str, Any] = {
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
        out.update(slopes=pi.slopes.tolist(), max_loop_width=pi.max_loop_width,
                   invertible=pi.is_invertible)
    if include_data:
        out["data"] = {"t": res.t.tolist(), "u": res.u.tolist(), "y": res.y.tolist()}
    return out
