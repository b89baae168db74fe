"""Imported once by the worker processes' forkserver (:data:`.worker.PRELOAD`), never by the
server: imports the solvers and runs one tiny fit of every fit kind and one tiny diagnosis, so
that the compiled kernels are loaded before any worker is forked from it.

Without it every worker would load them from numba's disk cache again (0.2 s for a PI fit,
1.7 s for a Preisach fit); with it a worker starts in about 10 ms. A failure here only costs
that time (it is caught: the forkserver must start whatever happens).
"""

from __future__ import annotations

import warnings


def warm() -> None:
    """Run each fit kind (3 operators) and a diagnosis on a 600-sample recording."""
    import numpy as np

    from app.services.jobs.tasks import run_diagnosis, run_fit
    from core.models import fit_kinds
    from core.recordings import Recording

    t = np.arange(600, dtype=np.float64) * 1e-3
    u = np.asarray(3 * np.sin(2 * np.pi * 5 * t), dtype=np.float64)
    rec = Recording(t, u, np.asarray(np.tanh(u) + 0.2 * u, dtype=np.float64))

    def quiet(fraction: float, message: str = "") -> None:
        pass

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fits = [run_fit(rec, 3, kind, progress=quiet).outcome for kind in fit_kinds()]
        run_diagnosis(rec, fits[-1].model, progress=quiet)
        # the figures of a heavy request (tasks.run_figures) load their kernels too
        from app.services.explore.config import Config, SignalSpec
        from app.services.jobs.tasks import run_figures
        from core.presets import get_preset, list_presets

        quick = ("time", "loop", "operators", "loading", "inverse")
        for p in list_presets():
            model = get_preset(p.name)
            cfg = Config(model=model.to_dict(), signal=SignalSpec(samples=200))
            run_figures(cfg, quick, 0, None, None, model, 100, 200_000, False, progress=quiet)


try:
    warm()
except Exception:  # noqa: BLE001 - only speed is lost
    pass
