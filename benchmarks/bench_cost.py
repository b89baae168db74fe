"""Does the priced cost bound the measured time? (issue 18, item 3)

Every registered model type prices its own run (:meth:`core.base.Model.cost`, summed over
the tree by :func:`app.services.explore.cost.check_model`). This benchmark simulates every type of
``tests/core/model_zoo.py`` plus scaled-up instances of the types whose work is not linear in
their fields, the inverses of the diagnosis's chains (each inverse type's own cost) and their
closed loops (chain and inverse stepped one sample per call, ``priced_steps``), best of 3
after a warm-up, and prints the measured seconds per priced work unit (one unit is meant
as about 1 ns). The price is a bound when the worst ratio stays below
:data:`MAX_SECONDS_PER_UNIT`; the exit status says whether it does. Single-threaded::

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python benchmarks/bench_cost.py
"""

from __future__ import annotations

import math
import sys
import time
import warnings

import numpy as np

from app.services.explore.cost import priced_run, priced_steps
from core.base import Model
from core.boucwen import BoucWenModel
from core.deadzone import DeadZoneMap
from core.lti import LinearSystem
from core.pi import PIModel
from core.preisach import PreisachModel
from core.stages import (
    Advance,
    Asymmetry,
    AsymmetryInverse,
    Creep,
    CreepInverse,
    Delay,
    Drift,
    RateDependentPI,
)
from tests.core.model_zoo import DIAGNOSED, DT, ZOO

#: Samples of the timed runs.
N = 40_000
#: Generous upper bound of measured seconds per priced unit (about 1 ns is typical).
MAX_SECONDS_PER_UNIT = 40e-9


def _scaled() -> dict[str, Model]:
    """Zoo types scaled up in the sizes their cost depends on."""
    k = 60
    pre = PreisachModel(np.linspace(0.0, 2.0, 12), np.full((12, 3), 0.05), knots=[-1.0, 1.0])
    # small saturations, powers and steep reversals: the most sub-steps per sample
    bw = BoucWenModel(1.0, np.full(20, -0.005), np.linspace(0.01, 0.5, 20), np.full(20, 6.0),
                      np.full(20, 3.7))
    return {
        "pi x100": PIModel(1.0, np.linspace(0.05, 3.0, 100), np.full(100, 0.01)),
        "creep x40": Creep(np.logspace(-3, 1, 40), np.full(40, 0.01)),
        "creep-inverse x40": CreepInverse(np.logspace(-3, 1, 40), np.full(40, 0.01)),
        "drift x400": Drift(np.full(400, 1e-3), 2.0),
        "deadzone x50": DeadZoneMap.symmetric(np.linspace(0.05, 3.0, 25), 0.9, np.full(25, 0.01)),
        "asymmetry x200": Asymmetry(np.full(200, 1e-4), 0.5, 4.0),
        "asymmetry-inverse x60": AsymmetryInverse(np.full(k, 1e-5), 0.5, 4.0),
        "delay long": Delay(N * DT), "advance long": Advance(N * DT),
        "rate x20": RateDependentPI(1.0, np.linspace(0.1, 2.0, 20), np.full(20, 0.02), 2e-5),
        "rate-inverse x20": RateDependentPI(1.0, np.linspace(0.1, 2.0, 20),
                                            np.full(20, 0.02), 2e-5).inverse(),
        "lti order 8": LinearSystem([1.0], np.poly(-np.arange(1, 9) * 1e3)),
        "preisach-inverse x12": pre.inverse(),
        "bouc-wen x20 stiff": bw,
        "bouc-wen-inverse x20 stiff": bw.inverse(),
    }


def _seconds(m: Model, u: np.ndarray) -> float:
    m.simulate(u[:64], dt=DT)  # compile the kernels first
    best = math.inf
    for _ in range(3):
        t = time.perf_counter()
        m.simulate(u, dt=DT)
        best = min(best, time.perf_counter() - t)
    return best


def measure() -> dict[str, float]:
    """Seconds per priced unit stay under one generous constant for every type, scaled up."""
    u = 3.0 * np.sin(np.linspace(0.0, 40.0 * np.pi, N))
    ratios: dict[str, float] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, m in {**ZOO, **_scaled(), **diagnosed_inverses()}.items():
            ratios[name] = _seconds(m, u) / priced_run(m, N, DT).work
        for name, (plant, ff) in DIAGNOSED_LOOPS.items():  # one sample per call
            ratios[f"{name} closed loop"] = _loop_seconds(plant, ff) / _loop_price(plant, ff)
    return ratios


def diagnosed_inverses() -> dict[str, Model]:
    """The inverses of the chains the diagnosis writes (the explorer's Inverse view of a
    diagnosed session runs them), priced from each inverse type's own cost."""
    return {f"{name} inverse": m.inverse() for name, m in DIAGNOSED.items()}


#: The diagnosed chains of the zoo with their inverses: the Closed-loop view's plant and
#: feedforward (``app.services.explore.simulation.priced_views``).
DIAGNOSED_LOOPS = {name: (m, m.inverse()) for name, m in DIAGNOSED.items()}
#: Samples of a timed closed loop (the explorer's, 0.02 s at 50 kHz).
LOOP_STEPS = 1000


def _loop_seconds(plant: Model, ff: Model) -> float:
    """Seconds of the plant-with-feedforward loop (paper 001's), best of 2."""
    from core.closed_loop import HammersteinLoop, paper001_plant

    r = 2.0 * np.sin(np.linspace(0.0, 6.0, LOOP_STEPS))
    loop = HammersteinLoop(plant, paper001_plant(), feedforward=ff)
    loop.simulate(r[:8], 2e-5)
    best = math.inf
    for _ in range(2):
        t = time.perf_counter()
        loop.simulate(r, 2e-5)
        best = min(best, time.perf_counter() - t)
    return best


def _loop_price(plant: Model, ff: Model) -> float:
    """Priced work of that loop: both stepped one sample per call (``priced_steps``)."""
    return (priced_steps(plant, LOOP_STEPS, 2e-5).work
            + priced_steps(ff, LOOP_STEPS, 2e-5).work)




def main() -> int:
    ratios = measure()
    for name, r in sorted(ratios.items(), key=lambda kv: -kv[1]):
        print(f"{name:<28} {r * 1e9:8.2f} ns per priced unit")
    worst = max(ratios, key=ratios.__getitem__)
    ok = ratios[worst] < MAX_SECONDS_PER_UNIT
    print(f"worst: {worst} {ratios[worst] * 1e9:.2f} ns "
          f"({'within' if ok else 'ABOVE'} {MAX_SECONDS_PER_UNIT * 1e9:g} ns)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
