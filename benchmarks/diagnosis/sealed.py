"""The SEALED set of the concealed-effect benchmark (issue 30). Do not tune rules on it.

Rules of the diagnosis are changed only against the development set (``generator.py``,
``families.py``, ``classes.py``). This module defines the sealed set, which is run once at
the end of a round and reported beside the development set; a gap between the two is a
finding to report, not to tune away. Changing anything here after seeing its results makes
it a development set: add a new sealed set instead (a new seed block, new ranges) and say so
in ``benchmarks/diagnosis/README.md``.

What differs from the development set:

* **seeds** 7000-7999 (the development set uses 0-1999);
* **parameter ranges**: each effect's size is drawn per case from a range that contains none
  of the development magnitudes (:data:`PI_RANGES`, :data:`OPENSEES_RANGES`);
* **excitations** the development set does not have (:func:`pi_signals`,
  :func:`opensees_signals`): a random-reversal trajectory with pauses and mixed rates, an
  odd random-phase multisine around a bias, a staircase with random levels, a cyclic
  protocol of growing amplitude;
* **base families**: OpenSees uniaxial materials (BoucWen, Steel02, a pinched Hysteretic)
  from an independent implementation (:mod:`benchmarks.diagnosis.opensees_plants`), with
  the effects written a second time outside ``core``
  (:mod:`benchmarks.diagnosis.output_effects`);
* **measured bases** (:mod:`benchmarks.diagnosis.measured`): the shipped recordings with a
  known effect on the measured output.

Classes and case ids (:data:`SEALED_CASES`):

``sealed/pi/<effect>/<seed>``, ``sealed/pi/null/<seed>``
    the benchmark's own B-PI truth plant and effects (``generator._plant_of``), other seeds,
    other ranges, the recordings of :func:`pi_signals`; white noise 0.05 um.
``sealed/opensees/<material>/<effect>/<seed>``, ``sealed/opensees/<material>/null/<seed>``
    an OpenSees material driven by the strains of :func:`opensees_signals` (2 kHz), noise
    0.2 % of each recording's output range, an effect applied to its output.
``sealed/opensees-single/<material>/<recording>/<seed>``
    a single recording of one material, nothing hidden (issue 30: single-recording nulls
    got invented dynamic names from the first loading from rest). Added after the first
    sealed run as a class of its own; no rule had been changed on the sealed results.
``measured/<base>/null``, ``measured/<base>/<effect>/<size>``
    :data:`benchmarks.diagnosis.measured.MEASURED_CASES`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from benchmarks.diagnosis.generator import EFFECTS as PI_EFFECTS
from benchmarks.diagnosis.generator import Scenario, _plant_of, truth_pi
from benchmarks.diagnosis.measured import MEASURED_CASES, make_measured
from benchmarks.diagnosis.output_effects import apply_effect
from core.recordings import Recording

__all__ = ["OPENSEES_EFFECTS", "OPENSEES_RANGES", "PI_RANGES", "SEALED_CASES", "SEALED_SEEDS",
           "SIGNAL_SEED", "draw_opensees", "draw_pi", "make_sealed", "opensees_signals",
           "pi_signals", "random_reversals"]

#: Seeds of the sealed set (the development set uses 0-1999).
SEALED_SEEDS = range(7000, 8000)
#: Seed of the sealed excitations (fixed: every case sees the same inputs).
SIGNAL_SEED = 7777
#: White noise of the sealed PI class (um; between the development's 0.02 and 0.1).
PI_NOISE_UM = 0.05
#: Noise of the OpenSees class, fraction of each recording's output range.
OPENSEES_NOISE = 0.002

#: Ranges (low, high) of the sealed PI effects, drawn uniformly per case; none contains a
#: development magnitude (L1/L2/L3 of ``generator.MAGNITUDES``, ``WEAK``).
PI_RANGES: dict[str, dict[str, tuple[float, float]]] = {
    "delay": {"delay_s": (150e-6, 250e-6)},
    "lag": {"tau_s": (200e-6, 380e-6)},
    "resonance": {"freq_hz": (260.0, 370.0), "damping": (0.03, 0.045)},
    "rate": {"beta_s": (4e-4, 8e-4)},
    "creep": {"gamma": (0.002, 0.004)},
    "drift": {"amplitude": (0.5, 1.0)},
    "asymmetry": {"a2": (0.4, 0.8)},
    "offset": {"spread": (0.4, 0.8)},
    "initial-memory": {"u0": (33.0, 42.0)},
}
#: Ranges of the OpenSees effects: delay in whole samples at 2 kHz (1-1.5 ms), mode
#: 120-260 Hz, creep total 3-6 % of a step over lags 0.01-10 s, drift 1-2 % of the range.
OPENSEES_RANGES: dict[str, dict[str, tuple[float, float]]] = {
    "delay": {"samples": (2, 3)},
    "resonance": {"freq_hz": (120.0, 260.0), "damping": (0.03, 0.07)},
    "creep": {"total": (0.03, 0.06)},
    "drift": {"pct": (1.0, 2.0)},
}
OPENSEES_EFFECTS = tuple(OPENSEES_RANGES)
OPENSEES_MATERIALS = ("os-boucwen", "os-steel02", "os-pinched")
#: Recordings of :func:`opensees_signals` (each alone is a single-recording null).
OPENSEES_RECORDINGS = ("cyclic", "reversals", "decaying", "staircase")
_CREEP_TAUS = (0.01, 0.1, 1.0, 10.0)

#: Every case of the sealed set.
SEALED_CASES: tuple[str, ...] = (
    *(f"sealed/pi/null/{s}" for s in (7000, 7001)),
    *(f"sealed/pi/{e}/7100" for e in PI_EFFECTS),
    *(f"sealed/opensees/{m}/null/{s}" for m in OPENSEES_MATERIALS for s in (7200, 7201)),
    *(f"sealed/opensees/{m}/{e}/{7300 + k}" for k, m in enumerate(OPENSEES_MATERIALS)
      for e in OPENSEES_EFFECTS),
    *(f"sealed/opensees-single/{m}/{r}/7400" for m in OPENSEES_MATERIALS
      for r in OPENSEES_RECORDINGS),
    *MEASURED_CASES,
)


# ----------------------------------------------------------------------------- excitations
def random_reversals(rng: np.random.Generator, lo: float, hi: float, duration_s: float,
                     fs: float, rates: tuple[float, float], pause_s: float,
                     start: float) -> np.ndarray:
    """A piecewise-linear input from ``start`` through random reversal levels in
    ``[lo, hi]``, each leg at a rate drawn log-uniformly in ``rates`` (units per s), a pause
    of up to ``pause_s`` at half of the reversals; ``duration_s`` at ``fs`` samples per s."""
    n = int(round(duration_s * fs))
    out = [np.array([start])]
    cur, total = start, 1
    while total < n:
        nxt = rng.uniform(lo, hi)
        while abs(nxt - cur) < 0.1 * (hi - lo):
            nxt = rng.uniform(lo, hi)
        rate = float(np.exp(rng.uniform(np.log(rates[0]), np.log(rates[1]))))
        m = max(2, int(round(abs(nxt - cur) / rate * fs)))
        leg = np.linspace(cur, nxt, m + 1)[1:]
        if rng.uniform() < 0.5:
            leg = np.concatenate((leg, np.full(int(rng.uniform(0, pause_s) * fs), nxt)))
        out.append(leg)
        total += leg.size
        cur = nxt
    return np.concatenate(out)[:n]


def _staircase(levels: list[float], hold_s: float, ramp: int, fs: float) -> np.ndarray:
    parts, prev = [], levels[0]
    for lv in levels[1:]:
        parts.append(np.linspace(prev, lv, ramp + 1)[1:])
        parts.append(np.full(int(hold_s * fs) - ramp, float(lv)))
        prev = lv
    return np.concatenate([np.full(int(hold_s * fs), float(levels[0])), *parts])


def pi_signals() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Recordings ``(name, t, u)`` of the sealed PI class (0-150 V), 80 k samples in all.

    ``reversals``: random reversal levels, legs at 100-25 000 V/s, pauses up to 0.4 s,
    from 0 V, 5 kHz, 8 s; ``multisine``: an odd random-phase multisine around 75 V (odd
    harmonics of 1 Hz up to 199 Hz, equal amplitudes, +-40 V peak), 4 periods, 5 kHz;
    ``staircase``: random levels 0-150 V, 1.5 s holds, 4 ms ramps, 1 kHz, 18 s.
    """
    rng = np.random.default_rng(SIGNAL_SEED)
    fs = 5000.0
    u = random_reversals(rng, 0.0, 150.0, 8.0, fs, (100.0, 25000.0), 0.4, 0.0)
    out = [("reversals", np.arange(u.size) / fs, u)]
    t = np.arange(int(4 * fs)) / fs
    k = np.arange(1, 200, 2)
    ph = rng.uniform(0, 2 * np.pi, k.size)
    ms = np.sin(2 * np.pi * np.outer(t, k) + ph).sum(axis=1)
    u = 75.0 + 40.0 * ms / np.max(np.abs(ms))
    out.append(("multisine", t, u))
    fs = 1000.0
    levels = [0.0, *np.round(rng.uniform(0, 150, 10), 1), 0.0]
    u = _staircase(levels, 1.5, 4, fs)
    out.append(("staircase", np.arange(u.size) / fs, u))
    return out


def opensees_signals() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Strain histories ``(name, t, strain)`` (mm/m) of the OpenSees class, 2 kHz, 67 k
    samples: ``cyclic`` (two triangle cycles at each amplitude 1-6 mm/m, 40 mm/m per s),
    ``reversals`` (random levels in +-6 mm/m, legs at 5-400 mm/m per s, pauses up to 0.4
    s, 8 s), ``decaying`` (2 Hz sine, amplitude 6 e^(-t/2) mm/m, 6 s), ``staircase``
    (0 -> 6 -> -6 -> 0 mm/m in 2 mm/m steps ramped over 5 ms, 1.2 s holds)."""
    rng = np.random.default_rng(SIGNAL_SEED + 1)
    fs = 2000.0
    nodes = [0.0]
    for a in range(1, 7):
        nodes += [a, -a, a, -a]
    nodes.append(0.0)
    parts = [np.array([0.0])]
    for a, b in zip(nodes[:-1], nodes[1:], strict=True):
        m = int(round(abs(b - a) / 40.0 * fs))
        parts.append(np.linspace(a, b, m + 1)[1:])
    u = np.concatenate(parts)
    out = [("cyclic", np.arange(u.size) / fs, u)]
    u = random_reversals(rng, -6.0, 6.0, 8.0, fs, (5.0, 400.0), 0.4, 0.0)
    out.append(("reversals", np.arange(u.size) / fs, u))
    t = np.arange(int(6 * fs)) / fs
    out.append(("decaying", t, 6.0 * np.exp(-t / 2.0) * np.sin(2 * np.pi * 2.0 * t)))
    u = _staircase([0, 2, 4, 6, 4, 2, 0, -2, -4, -6, -4, -2, 0], 1.2, 10, fs)
    out.append(("staircase", np.arange(u.size) / fs, u))
    return out


# ----------------------------------------------------------------------------- parameters
def draw_pi(effect: str, seed: int) -> dict[str, Any]:
    """The sealed PI effect's truth parameters of case ``seed`` (in ``generator`` form)."""
    rng = np.random.default_rng([seed, 30])
    p = {k: float(rng.uniform(*r)) for k, r in PI_RANGES[effect].items()}
    if effect == "initial-memory":
        return {"history": (p["u0"], 0.0)}
    return p


def draw_opensees(effect: str, seed: int) -> dict[str, Any]:
    """The OpenSees effect's size of case ``seed``: ``samples`` (dead time at 2 kHz),
    ``freq_hz`` / ``damping``, creep ``total``, drift ``pct``."""
    rng = np.random.default_rng([seed, 31])
    r = OPENSEES_RANGES[effect]
    if effect == "delay":
        return {"samples": int(rng.integers(r["samples"][0], r["samples"][1] + 1))}
    return {k: float(rng.uniform(*v)) for k, v in r.items()}


# ----------------------------------------------------------------------------- scenarios
def _make_pi(effect: str | None, seed: int) -> Scenario:
    hidden = {effect: draw_pi(effect, seed)} if effect else {}
    rng = np.random.default_rng(seed)
    recs, truths, worst = [], [], 0.0
    for k, (name, t, u) in enumerate(pi_signals()):
        dt = float(t[1] - t[0])
        m = _plant_of(hidden, k, t, rng)
        y_clean = m(u, dt=dt)
        y0 = truth_pi()(u)
        worst = max(worst, float(np.max(np.abs(y_clean - y0)) / np.ptp(y0)))
        recs.append(Recording(t, u, y_clean + PI_NOISE_UM * rng.standard_normal(u.size), name))
        truths.append(m)
    return Scenario(effect, f"white{PI_NOISE_UM:g}", seed, "sealed",
                    hidden.get(effect, {}) if effect else {}, recs, truths, 100 * worst,
                    extras={"hidden": hidden, "base": "B-PI",
                            "case": f"sealed/pi/{effect or 'null'}/{seed}"})


def _make_opensees(material: str, effect: str | None, seed: int,
                   only: str | None = None) -> Scenario:
    from benchmarks.diagnosis.opensees_plants import MATERIALS

    plant = MATERIALS[material]
    size = draw_opensees(effect, seed) if effect else {}
    rng = np.random.default_rng([seed, 0])
    recs, truths, worst = [], [], 0.0
    for name, t, u in opensees_signals():
        if only is not None and name != only:
            continue
        y0 = plant(u)
        dt = float(t[1] - t[0])
        tr: dict[str, Any] = {}
        if effect == "delay":
            tr = {"samples": size["samples"], "delay_s": size["samples"] * dt}
        elif effect == "resonance":
            tr = dict(size)
        elif effect == "creep":
            n = len(_CREEP_TAUS)
            tr = {"taus_s": list(_CREEP_TAUS), "weights": [size["total"] / n] * n}
        elif effect == "drift":
            tr = {"pct": size["pct"], "amount": size["pct"] / 100 * float(np.ptp(y0))}
        y = apply_effect(effect, t, y0, tr) if effect else y0
        worst = max(worst, float(np.max(np.abs(y - y0)) / np.ptp(y0)))
        y = y + OPENSEES_NOISE * float(np.ptp(y0)) * rng.standard_normal(u.size)
        recs.append(Recording(t, u, y, name, units={"input": "mm/m", "output": "MPa"}))
        truths.append(tr)
    case = (f"sealed/opensees/{material}/{effect or 'null'}/{seed}" if only is None else
            f"sealed/opensees-single/{material}/{only}/{seed}")
    hidden = {effect: truths[0]} if effect else {}
    return Scenario(effect, f"white{100 * OPENSEES_NOISE:g}%", seed, "sealed",
                    truths[0] if effect else {}, recs, [], 100 * worst,
                    extras={"hidden": hidden, "base": material, "case": case,
                            "per_recording": truths})


def make_sealed(case: str) -> Scenario:
    """The scenario of a sealed case id (:data:`SEALED_CASES`); ``extras["hidden"]`` holds
    effect -> truth parameters, ``extras["base"]`` the base (``B-PI``, a material, a
    measured base)."""
    parts = case.split("/")
    if parts[0] == "measured":
        return make_measured(case)
    try:
        if parts[:2] == ["sealed", "pi"] and len(parts) == 4:
            effect = None if parts[2] == "null" else parts[2]
            if effect is not None and effect not in PI_RANGES:
                raise KeyError(effect)
            return _make_pi(effect, int(parts[3]))
        if parts[:2] == ["sealed", "opensees"] and len(parts) == 5:
            effect = None if parts[3] == "null" else parts[3]
            if effect is not None and effect not in OPENSEES_RANGES:
                raise KeyError(effect)
            if parts[2] not in OPENSEES_MATERIALS:
                raise KeyError(parts[2])
            return _make_opensees(parts[2], effect, int(parts[4]))
        if parts[:2] == ["sealed", "opensees-single"] and len(parts) == 5:
            if parts[2] not in OPENSEES_MATERIALS or parts[3] not in OPENSEES_RECORDINGS:
                raise KeyError(parts[2])
            return _make_opensees(parts[2], None, int(parts[4]), only=parts[3])
    except (KeyError, ValueError):
        pass
    raise ValueError(f"unknown sealed case {case!r}; known: {', '.join(SEALED_CASES)}")
