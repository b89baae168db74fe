"""The oracle of the diagnosis benchmark: the held-out RMSE the true structure reaches.

:func:`oracle_rmse` fits the diagnosis structure with the hidden effects' true nonlinear
parameters (the gap closure of a diagnosis is measured against it); used by
``run_benchmark.py`` and the class runs of ``classes.py``.
"""

from __future__ import annotations

import numpy as np

from benchmarks.diagnosis.generator import magnitude
from core.diagnosis.data import split_masks
from core.diagnosis.grid import baseline_thresholds
from core.diagnosis.structure import Structure, fit_structure

__all__ = ["oracle_rmse"]


def oracle_rmse(records, effect: str | None, n_ops: int,
                lv: dict | None = None, hidden: dict | None = None) -> tuple[float, float]:
    """Held-out RMSE of the baseline structure and of the true-effect structure.

    ``lv``: the true parameters of the effect (default: its L2 magnitude); ``hidden``
    (name -> parameters) instead gives several effects at once. Effects the diagnosis
    structure cannot hold (loop-shape maps) are left out of the oracle.
    """
    tr, te, _ = split_masks(records)
    r = baseline_thresholds(records, tr, n_ops)
    base = Structure(tuple(float(x) for x in r), tuple(() for _ in records))
    if hidden is None:
        hidden = {effect: magnitude(effect, "L2") if lv is None else lv} if effect else {}
    s = base
    for name, p in hidden.items():
        s = _with_true(s, name, p, len(records))

    def rmse(st):
        f = fit_structure(st, records, tr)
        e = np.concatenate([(rec.y - p)[m] for rec, p, m in zip(records, f.pred, te,
                                                                strict=True)])
        return float(np.sqrt(np.mean(e * e)))

    b = rmse(base)
    return b, (rmse(s) if s != base else b)


def _with_true(s: Structure, effect: str, lv: dict, n_rec: int) -> Structure:
    """``s`` with the true structure of ``effect`` (true nonlinear parameters)."""
    if effect in ("delay", "lag"):
        return s.with_(dynamics=(effect, next(iter(lv.values()))))
    if effect == "resonance":
        return s.with_(dynamics=("resonance", lv["freq_hz"], lv["damping"]))
    if effect == "rate":
        return s.with_(beta_s=lv["beta_s"])
    if effect == "creep":
        return s.with_term("creep", (0.01, 0.1, 1.0, 10.0, 100.0))
    if effect == "drift":
        return s.with_term("drift", 4)
    if effect == "asymmetry":
        return s.with_term("asymmetry", True)
    if effect == "offset":
        return s.with_term("offset", True)
    if effect == "initial-memory":
        return s.with_(history=(tuple(lv["history"]),) + tuple(() for _ in range(n_rec - 1)))
    return s  # loop-shape maps: not representable in the diagnosis structure here
