"""Missing-physics diagnosis: LOCATE where a PI model and a recording differ, SAY which physics
was left out, MODEL it as an effect stage, SHOW the held-out improvement (or say the recordings
cannot tell).

The design follows ``shared/notes/missing-physics.md`` (catalog §3, engine §5); the effect
models live in :mod:`core.stages`.

Examples
--------
>>> from core.diagnosis import diagnose                                   # doctest: +SKIP
>>> res = diagnose("piezo.csv", train=(3.3, 7.0), test=(7.0, 9.0))      # doctest: +SKIP
>>> [e.name for e in res.effects], res.model                            # doctest: +SKIP
"""

from __future__ import annotations

from ..threads import with_thread_limit
from . import effects  # noqa: F401  (registers every diagnosable effect)
from .data import as_records, split_masks
from .engine import ACCEPT_RULE, DiagnosisResult, EffectFinding
from .engine import diagnose as _diagnose
from .structure import Fit, Structure, fit_structure

#: The entry point: one BLAS / OpenMP / numba thread unless ``threads=`` asks for more, the
#: caller's settings restored afterwards (:mod:`core.threads`).
diagnose = with_thread_limit(_diagnose)

__all__ = [
    "ACCEPT_RULE",
    "DiagnosisResult",
    "EffectFinding",
    "Fit",
    "Structure",
    "as_records",
    "diagnose",
    "fit_structure",
    "split_masks",
]
