"""One instance of every registered model type (shared by the JSON, MAT, C and FMU export
tests), and the chains the diagnosis writes.

``ZOO[type_name]`` is a model of that type; a new ``@register_model`` type must be added here
(``test_every_registered_type_has_an_instance`` fails until it is).
"""

from __future__ import annotations

import tracemalloc

import numpy as np

from core.base import Chain, Model
from core.boucwen import BoucWenModel
from core.deadzone import DeadZoneMap
from core.digitized import DigitizedPI
from core.digitized_deadzone import DigitizedDeadZone, DigitizedModifiedPI
from core.gpi import DeadZoneGPI, ModifiedPI, TanhEnvelope, TanhGPI
from core.lti import LinearSystem
from core.nonmasing import MenegottoPintoModel
from core.pi import PIModel
from core.preisach import PreisachModel, RateDependentPreisach
from core.stages import (
    Advance,
    Asymmetry,
    AsymmetryInverse,
    Creep,
    CreepInverse,
    Delay,
    Drift,
    InitialMemory,
    Lag,
    LagInverse,
    Offset,
    RateDependentPI,
    Resonance,
    ResonanceInverse,
    SignedGain,
)
from core.stop import StopPIModel

#: Paper 001, Example 1 (input about ±4).
EX1 = PIModel(0.72, [0.45 * i for i in range(1, 7)], [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])
#: A level-dependent Preisach model (input about ±3): minor loops widen with the bias.
PREISACH = PreisachModel(
    [0.0, 0.5, 1.0, 1.5],
    [[0.8, 0.7, 0.9], [0.2, 0.35, 0.5], [0.1, 0.2, 0.3], [0.05, 0.05, 0.15]],
    knots=[-1.0, 1.0],
    state0=[0.0, 0.2, -0.3, 0.1],
)
#: A Bouc-Wen bank of three elements (input about ±3), started off zero.
BOUC_WEN = BoucWenModel(
    1.0,
    [-0.25, -0.15, 0.1],
    [0.5, 1.5, 1.0],
    [1.5, 2.5, 1.0],
    [1.0, 2.0, 1.5],
    state0=[0.1, -0.2, 0.0],
    input0=0.5,
)
#: The same with relay thresholds widened by 2e-5 s x |du/dt| (β/dt = 0.2 at :data:`DT`).
RATE_PREISACH = RateDependentPreisach(PREISACH.thresholds, PREISACH.weights, 2e-5,
                                      PREISACH.knots, PREISACH.state0)
#: A stop-operator PI (Maxwell-slip, clockwise loops; input about ±3), sliders off zero.
STOP_PI = StopPIModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4], state0=[0.1, -0.2, 0.3])
#: The same behind a backlash gap 0.4 wide (a friction damper with a loose joint).
STOP_GAP = StopPIModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4], state0=[0.1, -0.2, 0.3],
                       gap=0.4)
#: A Menegotto-Pinto bank (non-Masing, clockwise loops; input about ±3): a rounder knee
#: after larger excursions.
MENEGOTTO_PINTO = MenegottoPintoModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4], [20.0, 8.0, 3.0],
                                      [0.9, 0.5, 0.0], [0.15, 0.5, 1.0])
#: Sample spacing used with the dynamic models (s).
DT = 1e-4


def turning_points(seed: int, n: int) -> np.ndarray:
    """Piecewise-linear input of ``n`` samples through random turning points in [-3, 3]
    (nested loops), starting at 0."""
    rng = np.random.default_rng(seed)
    out, total, a = [], 0, 0.0
    while total < n:
        b = float(rng.uniform(-3.0, 3.0))
        m = int(rng.integers(20, 200))
        out.append(np.linspace(a, b, m, endpoint=False))
        total, a = total + m, b
    return np.concatenate(out)[:n]


def traced_peak(m: Model, u: np.ndarray, dt: float) -> int:
    """Peak bytes :mod:`tracemalloc` sees while ``m`` simulates ``u`` (numpy reports its
    buffers to it); the kernels are compiled on a short run first, outside the trace."""
    m.simulate(u[:64], dt=dt)
    tracemalloc.start()
    try:
        m.simulate(u, dt=dt)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak


def _zoo() -> dict[str, Model]:
    g = DeadZoneMap.symmetric([0.8, 1.6], 0.9, [0.4, -0.3])
    env = TanhEnvelope([6.0, 0.4, 0.0, -0.2], [6.0, 0.4, 0.0, 0.2], direction0=-1)
    rate = RateDependentPI(1.0, [0.5, 1.0], [0.3, 0.2], 2e-5)
    dig = DigitizedPI.from_pi(EX1, (-5.0, 5.0), state0="0110101")
    out: dict[str, Model] = {
        "pi": EX1,
        "chain": Chain.of(EX1, Creep([0.01, 0.1], [0.02, 0.01]), Offset(0.2)),
        "offset": Offset(0.5),
        "signed-gain": SignedGain(1.0, 1.8),
        "lag": Lag(1e-3),
        "lag-inverse": LagInverse(1e-3),
        "resonance": Resonance(300.0, 0.1),
        "resonance-inverse": ResonanceInverse(300.0, 0.1, 900.0),
        "delay": Delay(2.5e-4),
        "advance": Advance(2.5e-4),
        "creep": Creep([0.01, 0.1, 1.0], [0.02, 0.01, 0.03]),
        "creep-inverse": CreepInverse([0.01, 0.1, 1.0], [0.02, 0.01, 0.03]),
        "drift": Drift([0.1, -0.05], 2.0),
        "asymmetry": Asymmetry([0.1, 0.02], 0.5, 2.0),
        "asymmetry-inverse": AsymmetryInverse([0.1, 0.02], 0.5, 2.0),
        "rate": rate,
        "rate-inverse": rate.inverse(),
        "initial-memory": InitialMemory(EX1, [2.0, -1.0]),
        "deadzone": g,
        "gpi-deadzone": DeadZoneGPI(EX1, g),
        "mpi": ModifiedPI(EX1, g),
        "tanh-envelope": env,
        "tanh-envelope-inverse": env.inverse(),
        "gpi-tanh": TanhGPI(EX1, env),
        "digitized": dig,
        "lti": LinearSystem([5e-4, 1.0], [1e-3, 1.0]),
        "preisach": PREISACH,
        "preisach-inverse": PREISACH.inverse(),
        "bouc-wen": BOUC_WEN,
        "bouc-wen-inverse": BOUC_WEN.inverse(),
        "rate-preisach": RATE_PREISACH,
        "rate-preisach-inverse": RATE_PREISACH.inverse(),
        "stop-pi": STOP_PI,
        "stop-pi-gap-inverse": STOP_GAP.inverse(),
        "menegotto-pinto": MENEGOTTO_PINTO,
        "menegotto-pinto-inverse": MENEGOTTO_PINTO.inverse(),
    }
    out["lti_inverse"] = LinearSystem([1e-4, 1.0], [1e-3, 1.0]).inverse()
    out["digitized-deadzone"] = DigitizedDeadZone.from_deadzone_map(g)
    out["digitized-mpi"] = DigitizedModifiedPI.from_modified_pi(ModifiedPI(EX1, g), (-5.0, 5.0))
    return out


ZOO = _zoo()
#: Extra chains the diagnosis writes: the PI baseline followed by each accepted effect.
DIAGNOSED: dict[str, Model] = {
    "diag-creep-offset": Chain.of(EX1, ZOO["creep"], ZOO["offset"]),
    "diag-lag-delay": Chain.of(EX1, Lag(2e-4), Delay(3e-4)),
    "diag-resonance": Chain.of(EX1, Resonance(400.0, 0.05)),
    "diag-asym-drift": Chain.of(EX1, ZOO["asymmetry"], ZOO["drift"]),
    "diag-rate-memory": Chain.of(ZOO["initial-memory"], ZOO["creep"]),
    "diag-preisach-memory": Chain.of(InitialMemory(PREISACH, [2.5, -1.5]), ZOO["offset"]),
    "diag-friction-gap": Chain.of(STOP_GAP, ZOO["offset"]),
    "diag-friction-gap-signed": Chain.of(STOP_GAP, ZOO["signed-gain"], ZOO["offset"]),
}
