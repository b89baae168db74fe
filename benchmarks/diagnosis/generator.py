"""Concealed-effect scenarios for the missing-physics benchmark (notes §7).

Truth plant (B-PI of the notes): ``p0 = 0.55 um/V``, plays at ``r = 15, 30, ..., 135 V`` with
``p_i = 0.12 exp(-0.02 r_i) um/V``, unipolar 0-150 V input (about 100 um stroke). Each scenario
adds at most one hidden effect, at one of three magnitude levels (:data:`MAGNITUDES`: L1
subtle, L2 the original benchmark magnitude, L3 obvious), and produces three recordings a
user would plausibly have:

``decaying``
    1 Hz sine around mid-range with amplitude decaying from full stroke (nested reversals),
    2.5 kHz, 6 s.
``multisine``
    full-stroke sines, 2 cycles at 1 Hz, 10 at 10 Hz, 25 at 50 Hz, 40 at 100 Hz, then a 1 Hz
    triangle, 5 kHz, 4.9 s.
``staircase``
    up-then-down staircase 0 → 150 → 0 V in 30 V steps ramped over 5 ms, 2 s holds, 1 kHz,
    20 s.

Noise models: ``white1`` 0.02 um, ``white2`` 0.1 um, ``coloured``: 0.02 um white + AR(1)
(φ = 0.999, equal variance) + 50 Hz hum (0.5 σ) + 16-bit quantisation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from core.base import Chain, Model
from core.deadzone import DeadZoneMap
from core.pi import PIModel
from core.recordings import Recording
from core.stages import (
    Asymmetry,
    Creep,
    Delay,
    Drift,
    InitialMemory,
    Lag,
    Offset,
    RateDependentPI,
    Resonance,
)

__all__ = ["AMPLITUDES", "COMBOS", "EFFECTS", "LEVELS", "LEVEL_NAMES", "MAGNITUDES", "SHAPES",
           "WEAK", "Scenario", "magnitude", "make_amplitude_set", "make_closed_loop", "make_combo",
           "make_periodic_set", "make_scenario", "make_shape", "make_single_staircase",
           "make_weak", "scenario_id", "truth_pi"]

R_TRUE = np.arange(15.0, 136.0, 15.0)
P0_TRUE = 0.55
W_TRUE = 0.12 * np.exp(-0.02 * R_TRUE)
STROKE_APPROX = 100.0  # um

#: Magnitude of every hidden effect per level. L2 ("concealed-moderate") is the original
#: benchmark magnitude and must stay unchanged (old results stay comparable); L1 ("subtle")
#: is a third to a fifth of L2 (some runs near the detection limit, notes §7.2); L3
#: ("obvious") about 3x L2. Resonance scales by its frequency (the quasi-static error of a
#: mode goes as (f / f_n)^2); initial memory by the prior excursion U0 (the truth plant's
#: lowest threshold is 15 V, so the memory error is w_15 (U0 - 15) + w_30 (U0 - 30)+ ...).
MAGNITUDES: dict[str, dict[str, dict[str, Any]]] = {
    "L1": {
        "delay": {"delay_s": 20e-6},
        "lag": {"tau_s": 30e-6},
        "resonance": {"freq_hz": 900.0, "damping": 0.05},
        "rate": {"beta_s": 6e-5},
        "creep": {"gamma": 0.0005},
        "drift": {"amplitude": 0.13},
        "asymmetry": {"a2": 0.06},
        "offset": {"spread": 0.1},
        "initial-memory": {"history": (20.0, 0.0)},
    },
    "L2": {
        "delay": {"delay_s": 100e-6},
        "lag": {"tau_s": 150e-6},
        "resonance": {"freq_hz": 400.0, "damping": 0.05},
        "rate": {"beta_s": 3e-4},
        "creep": {"gamma": 0.0015},
        "drift": {"amplitude": 0.4},
        "asymmetry": {"a2": 0.3},
        "offset": {"spread": 0.3},
        "initial-memory": {"history": (30.0, 0.0)},
    },
    "L3": {
        "delay": {"delay_s": 300e-6},
        "lag": {"tau_s": 450e-6},
        "resonance": {"freq_hz": 230.0, "damping": 0.05},
        "rate": {"beta_s": 9e-4},
        "creep": {"gamma": 0.0045},
        "drift": {"amplitude": 1.2},
        "asymmetry": {"a2": 0.9},
        "offset": {"spread": 0.9},
        "initial-memory": {"history": (45.0, 0.0)},
    },
}
LEVEL_NAMES = tuple(MAGNITUDES)
#: The L2 magnitudes (the original table; kept under its old name).
LEVELS: dict[str, dict[str, Any]] = MAGNITUDES["L2"]
EFFECTS = tuple(LEVELS)


def magnitude(effect: str | None, level: str = "L2") -> dict[str, Any]:
    """The truth parameters of ``effect`` at ``level`` (empty for a null scenario)."""
    if level not in MAGNITUDES:
        raise ValueError(f"unknown level {level!r}; known: {', '.join(LEVEL_NAMES)}")
    return dict(MAGNITUDES[level].get(effect or "", {}))


def scenario_id(effect: str | None, level: str, noise: str, seed: int) -> str:
    """Reproducible id ``effect/level/noise/seed`` (nulls have level ``-``)."""
    return f"{effect or 'null'}/{level if effect else '-'}/{noise}/{seed}"


def truth_pi() -> PIModel:
    """The B-PI truth plant."""
    return PIModel(P0_TRUE, R_TRUE, W_TRUE)


def _signals() -> list[tuple[str, np.ndarray, np.ndarray]]:
    out = []
    fs = 2500.0
    t = np.arange(0, 6.0, 1 / fs)
    amp = 75.0 * np.exp(-t / 4.0)
    u = 75.0 - amp * np.cos(2 * np.pi * 1.0 * t)
    u = np.concatenate((np.zeros(int(0.2 * fs)), np.linspace(0, 0, 0)[:0], u))
    u[: int(0.2 * fs)] = u[int(0.2 * fs)]
    out.append(("decaying", np.arange(u.size) / fs, u))
    fs = 5000.0
    segs = []
    for f, cyc in ((1.0, 2), (10.0, 10), (50.0, 25), (100.0, 40)):
        tt = np.arange(0, cyc / f, 1 / fs)
        segs.append(75.0 - 75.0 * np.cos(2 * np.pi * f * tt))
    tt = np.arange(0, 1.0, 1 / fs)
    tri = 150.0 * (1 - np.abs(2 * ((tt * 1.0) % 1.0) - 1))
    segs.append(tri)
    u = np.concatenate(segs)
    out.append(("multisine", np.arange(u.size) / fs, u))
    fs = 1000.0
    levels = [0, 30, 60, 90, 120, 150, 120, 90, 60, 30, 0]
    parts = []
    prev = 0.0
    for lv in levels:
        ramp = np.linspace(prev, lv, 6)[1:]
        parts.append(ramp)
        parts.append(np.full(int(2.0 * fs) - 5, float(lv)))
        prev = lv
    u = np.concatenate(parts)
    out.append(("staircase", np.arange(u.size) / fs, u))
    return out


def _plant(effect: str | None, k: int, t: np.ndarray, rng: np.random.Generator,
           level: str = "L2", params: dict[str, Any] | None = None) -> Model:
    """Truth plant of recording ``k`` with one hidden effect (or none)."""
    lv = magnitude(effect, level) if params is None else dict(params)
    return _plant_of({effect: lv} if effect else {}, k, t, rng)


def _plant_of(hidden: dict[str, dict[str, Any]], k: int, t: np.ndarray,
              rng: np.random.Generator) -> Model:
    """Truth plant of recording ``k`` with every effect of ``hidden`` (name -> parameters),
    stages in the physical order: input map, hysteresis, output maps, slow effects,
    dynamics, sensor."""
    pi = truth_pi()
    stages: list[Model] = []
    if "dead-zone" in hidden:
        # a one-sided dead band on the input (a thresholded actuator): slope eta0 below
        # the threshold, 1 above it
        lv = hidden["dead-zone"]
        stages.append(DeadZoneMap([0.0, lv["threshold_v"]],
                                  [lv["eta0"], 1.0 - lv["eta0"]]))
    if "rate" in hidden:
        stages.append(RateDependentPI(P0_TRUE, R_TRUE, W_TRUE, hidden["rate"]["beta_s"]))
    elif "initial-memory" in hidden and k == 0:
        stages.append(InitialMemory(pi, list(hidden["initial-memory"]["history"])))
    else:
        stages.append(pi)
    if "saturation" in hidden:
        # the output slope drops by `drop` above `knee_um` (a saturating loop top)
        lv = hidden["saturation"]
        stages.append(DeadZoneMap([0.0, lv["knee_um"]], [1.0, -lv["drop"]]))
    if "asymmetry" in hidden:
        stages.append(Asymmetry([hidden["asymmetry"]["a2"], 0.0], 0.5 * STROKE_APPROX * 1.05,
                                50.0))
    if "creep" in hidden:
        taus = [0.01, 0.1, 1.0, 10.0, 100.0]
        stages.append(Creep(taus, [hidden["creep"]["gamma"]] * len(taus)))
    if "delay" in hidden:
        stages.append(Delay(hidden["delay"]["delay_s"]))
    if "lag" in hidden:
        stages.append(Lag(hidden["lag"]["tau_s"]))
    if "resonance" in hidden:
        stages.append(Resonance(hidden["resonance"]["freq_hz"], hidden["resonance"]["damping"]))
    if "offset" in hidden:
        stages.append(Offset(hidden["offset"]["spread"] * (-1.0, 1.0, 0.3)[k % 3]))
    if "drift" in hidden:
        span = float(t[-1] - t[0])
        # a ramp plus a slow wander, expressed on the Legendre basis of the drift model
        s = 2 * (t - t[0]) / span - 1
        d = hidden["drift"]["amplitude"] * (0.5 * s + 0.3 * np.sin(1.3 * s + rng.uniform(0, 2)))
        coef = np.polynomial.legendre.legfit(s, d, 4)[1:]
        stages.append(Drift(coef, span))
    return Chain.of(*stages)


def _noise(kind: str, n: int, fs: float, rng: np.random.Generator) -> np.ndarray:
    if kind == "white1":
        return 0.02 * rng.standard_normal(n)
    if kind == "white2":
        return 0.1 * rng.standard_normal(n)
    if kind == "coloured":
        import scipy.signal as ss

        w = 0.02 * rng.standard_normal(n)
        phi = 0.999
        ar = ss.lfilter([1.0], [1.0, -phi], rng.standard_normal(n)) * np.sqrt(1 - phi**2) * 0.02
        t = np.arange(n) / fs
        hum = 0.01 * np.sin(2 * np.pi * 50 * t + rng.uniform(0, 6.28))
        return w + ar + hum
    raise ValueError(f"unknown noise {kind!r}")


@dataclass
class Scenario:
    """A generated scenario: recordings, truth and concealment numbers."""

    effect: str | None
    noise: str
    seed: int
    level: str
    params: dict[str, Any]
    records: list[Recording]
    truth: list[Model]
    concealment_pct: float
    extras: dict[str, Any] = field(default_factory=dict)


def make_scenario(effect: str | None, noise: str = "white1", seed: int = 0,
                  level: str = "L2", params: dict[str, Any] | None = None) -> Scenario:
    """Generate one scenario (``effect=None`` is a null scenario).

    ``level`` picks the magnitude from :data:`MAGNITUDES`; ``params`` overrides it (for
    calibration). The noise realisation depends on ``seed`` only, so the same seed gives the
    same noise at every level (and for every effect except drift, which draws its wander
    phase first). ``concealment_pct`` is the max |δ| (raw effect before any refit) over the 1 Hz and
    10 Hz parts of the multisine recording and the decaying recording, in % of the stroke.
    """
    lv = magnitude(effect, level) if params is None else dict(params)
    return _scenario({effect: lv} if effect else {}, noise, seed, level)


def _scenario(hidden: dict[str, dict[str, Any]], noise: str, seed: int, level: str,
              signals: list[tuple[str, np.ndarray, np.ndarray]] | None = None) -> Scenario:
    """The recordings of :func:`_signals` (or ``signals``) through the plant with ``hidden``."""
    rng = np.random.default_rng(seed)
    recs, truths = [], []
    worst = 0.0
    for k, (name, t, u) in enumerate(_signals() if signals is None else signals):
        dt = float(t[1] - t[0])
        m = _plant_of(hidden, k, t, rng)
        y_clean = m(u, dt=dt)
        y0 = truth_pi()(u)
        stroke = float(np.ptp(y0)) or 1.0
        if name == "multisine":
            seg = slice(0, int(3.0 / dt))  # 1 Hz + 10 Hz parts
        else:
            seg = slice(None)
        if name != "staircase":
            worst = max(worst, float(np.max(np.abs(y_clean[seg] - y0[seg]))) / stroke * 100)
        y = y_clean + _noise(noise, u.size, 1 / dt, rng)
        if noise == "coloured":
            lsb = 2 * STROKE_APPROX / 2**16
            y = np.round(y / lsb) * lsb
        recs.append(Recording(t, u, y, name))
        truths.append(m)
    effect = "+".join(hidden) if hidden else None
    params = next(iter(hidden.values())) if len(hidden) == 1 else {
        f"{e}.{k}": v for e, lv in hidden.items() for k, v in lv.items()}
    return Scenario(effect, noise, seed, level, params, recs, truths, worst,
                    extras={"hidden": {e: dict(lv) for e, lv in hidden.items()}})


# ----------------------------------------------------------------------------- issue-8 classes
#: Two hidden effects at once (issue 8, failure 4: creep + delay, resonance + drift,
#: creep + asymmetry; plus lag + drift and delay + initial-memory), each at its L2 magnitude.
COMBOS: tuple[tuple[str, str], ...] = (
    ("creep", "delay"), ("resonance", "drift"), ("creep", "asymmetry"), ("lag", "drift"),
    ("delay", "initial-memory"),
)


def make_combo(effects: tuple[str, ...], noise: str = "white1", seed: int = 0,
               level: str = "L2") -> Scenario:
    """The three recordings through a plant with every effect of ``effects`` at ``level``;
    ``scenario.effect`` is the names joined by ``+``, ``extras["hidden"]`` their parameters."""
    return _scenario({e: magnitude(e, level) for e in effects}, noise, seed, level)


#: Weak effects (level "weak"): about a third of L1, at or below the detection limit at
#: 0.02 um noise; abstaining or a "suggestive" mention is right there, a wrong name is not.
WEAK: dict[str, dict[str, Any]] = {
    "delay": {"delay_s": 7e-6},
    "lag": {"tau_s": 10e-6},
    "resonance": {"freq_hz": 1600.0, "damping": 0.05},
    "rate": {"beta_s": 2e-5},
    "creep": {"gamma": 0.00017},
    "drift": {"amplitude": 0.045},
    "asymmetry": {"a2": 0.02},
    "initial-memory": {"history": (17.0, 0.0)},
}


def make_weak(effect: str, noise: str = "white1", seed: int = 0) -> Scenario:
    """One hidden effect at its :data:`WEAK` magnitude (level ``"weak"``)."""
    return _scenario({effect: dict(WEAK[effect])}, noise, seed, "weak")


def make_single_staircase(effect: str | None, noise: str = "white1", seed: int = 0,
                          level: str = "L2") -> Scenario:
    """A single-recording user (issue 8, failure 4): only the up-then-down staircase with
    holds (30 V steps ramped over 5 ms, 2 s holds, 1 kHz, 22 s), the recording one makes to
    look for creep; ``effect`` None (no hidden effect) or one effect at ``level``."""
    sig = [s for s in _signals() if s[0] == "staircase"]
    return _scenario({effect: magnitude(effect, level)} if effect else {}, noise, seed, level,
                     signals=sig)


#: Loop-shape scenarios (issue 8, failure 2): the expected effect name and the truth.
#: ``saturation``: the output slope drops by 45 % above 60 um (about 60 % of the stroke);
#: ``dead-zone``: a one-sided dead band, input slope 5 % below 25 V (a thresholded actuator).
SHAPES: dict[str, dict[str, Any]] = {
    "saturation": {"knee_um": 60.0, "drop": 0.45},
    "dead-zone": {"threshold_v": 25.0, "eta0": 0.05},
}


def make_shape(kind: str, noise: str = "white1", seed: int = 0) -> Scenario:
    """The three recordings through the B-PI with a loop-shape map (:data:`SHAPES`), built from
    the core's own :class:`~core.deadzone.DeadZoneMap` (input side for the dead band, output
    side for the saturation)."""
    return _scenario({kind: dict(SHAPES[kind])}, noise, seed, "shape")


# ----------------------------------------------------------------------------- periodic sets
#: Frequencies (Hz) of the short periodic recordings of :func:`make_periodic_set`.
PERIODIC_FREQS = (0.5, 1.0, 2.0, 4.0)


def loop_area(u: np.ndarray, y: np.ndarray) -> float:
    """Area enclosed by the closed loop ``(u, y)`` of one period (shoelace formula)."""
    return float(0.5 * abs(np.dot(u, np.roll(y, -1)) - np.dot(y, np.roll(u, -1))))


def make_periodic_set(beta_s: float | None, freqs: tuple[float, ...] = PERIODIC_FREQS,
                      cycles: int = 3, samples_per_cycle: int = 40, noise: float = 0.02,
                      seed: int = 0) -> Scenario:
    """Several short periodic recordings (full-stroke cosines), one per frequency.

    Each recording holds ``cycles`` periods of ``samples_per_cycle`` samples (the sampling
    rate follows the frequency), a user's "a few cycles at a few rates". The plant is the
    B-PI truth, rate-dependent (:class:`~core.stages.RateDependentPI`, ``beta_s`` in s)
    unless ``beta_s`` is None. ``extras["loop_area"]`` lists the noise-free steady-state
    loop area of the last cycle per recording (input units x output units).
    """
    rng = np.random.default_rng(seed)
    plant: Model = truth_pi() if beta_s is None else RateDependentPI(
        P0_TRUE, R_TRUE, W_TRUE, beta_s)
    recs, truths, areas = [], [], []
    for f in freqs:
        fs = samples_per_cycle * f
        t = np.arange(cycles * samples_per_cycle) / fs
        u = 75.0 - 75.0 * np.cos(2 * np.pi * f * t)
        y_clean = plant(u, dt=1 / fs)
        last = slice(-samples_per_cycle, None)
        areas.append(loop_area(u[last], y_clean[last]))
        y = y_clean + noise * rng.standard_normal(u.size)
        recs.append(Recording(t, u, y, name=f"sine-{f:g}Hz"))
        truths.append(plant)
    return Scenario(effect=None if beta_s is None else "rate", noise=f"white{noise:g}",
                    seed=seed, level="-", params={} if beta_s is None else {"beta_s": beta_s},
                    records=recs, truth=truths, concealment_pct=0.0,
                    extras={"loop_area": areas, "freqs_hz": list(freqs)})


#: Input amplitudes (fraction of the 0-150 V range, peak to peak) of :func:`make_amplitude_set`.
AMPLITUDES = (0.25, 0.5, 0.75, 1.0)


def make_amplitude_set(a2: float | None, amps: tuple[float, ...] = AMPLITUDES,
                       freq: float = 1.0, cycles: int = 3, samples_per_cycle: int = 60,
                       noise: float = 0.02, seed: int = 0) -> Scenario:
    """Several short periodic recordings at one frequency and different amplitudes (cosines
    from 0 V up to ``amp x 150 V``), one per amplitude: a user's "a few loops of growing
    size". The plant is the B-PI truth followed by the quadratic output map of the
    asymmetry scenarios (``a2`` um at the range ends) unless ``a2`` is None."""
    rng = np.random.default_rng(seed)
    stages: list[Model] = [truth_pi()]
    if a2 is not None:
        stages.append(Asymmetry([a2, 0.0], 0.5 * STROKE_APPROX * 1.05, 50.0))
    plant = Chain.of(*stages)
    recs, truths = [], []
    for a in amps:
        fs = samples_per_cycle * freq
        t = np.arange(cycles * samples_per_cycle) / fs
        u = 75.0 * a * (1 - np.cos(2 * np.pi * freq * t))
        y = plant(u, dt=1 / fs) + noise * rng.standard_normal(u.size)
        recs.append(Recording(t, u, y, name=f"sine-{100 * a:g}%"))
        truths.append(plant)
    return Scenario(effect=None if a2 is None else "asymmetry", noise=f"white{noise:g}",
                    seed=seed, level="-", params={} if a2 is None else {"a2": a2},
                    records=recs, truth=truths, concealment_pct=0.0,
                    extras={"amplitudes": list(amps)})


def make_closed_loop(noise: str = "white1", seed: int = 0, samples: int = 200) -> Scenario:
    """A single closed loop (one 1 Hz full-stroke cycle, as a measured B-H loop is): cut from
    the periodic steady state of the B-PI truth, starting at the bottom of the cycle, where
    the virgin memory differs from the cycle's own. No hidden effect: an ``initial-memory``
    claim would be an artefact."""
    rng = np.random.default_rng(seed)
    t = np.arange(3 * samples + 1) / samples
    u = 75.0 - 75.0 * np.cos(2 * np.pi * t)
    y = truth_pi()(u)[2 * samples:] + _noise(noise, samples + 1, float(samples), rng)
    rec = Recording(t[: samples + 1], u[2 * samples:], y, "closed loop")
    return Scenario(None, noise, seed, "-", {}, [rec], [truth_pi()], 0.0)


#: Short periodic recordings (``make_periodic_set``): class -> (beta_s, frequencies).
PERIODIC_CLASSES: dict[str, tuple[float | None, tuple[float, ...]]] = {
    "null (PI, 4 frequencies)": (None, PERIODIC_FREQS),
    "weaker rate (loop area +3 %)": (0.0006, PERIODIC_FREQS),
    "weak rate (loop area +9 %)": (0.002, PERIODIC_FREQS),
    "rate (loop area +2/3)": (0.025, PERIODIC_FREQS),
    "rate, one frequency (untestable)": (0.025, (1.0, 1.0, 1.0, 1.0)),
}
