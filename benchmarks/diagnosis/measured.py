"""Measured-base class of the sealed benchmark (issue 30): real hysteresis, a known effect.

The base is a shipped measured recording with a time axis (``core.datasets``): the piezo
actuator (``piezo-150V-1Hz``, 5 kHz, 10 s: a 0 V rest, one jump to -87 V, a 1 Hz sine of
about 6.7 cycles), the friction damper at 30 lb band tension (the 0.25, 1 and 2 Hz tests
together, 1024 Hz, one diagnosis of three recordings) and at 36 lb (the 1 Hz test). The B(H)
loops have no time axis and carry no time effect; they are not used.

A known effect (:mod:`benchmarks.diagnosis.output_effects`) is applied to the measured
OUTPUT at two sizes, one of them the size issue 30 reports (piezo: 1 ms dead time, 350 Hz
mode, drift 2 % of range; friction: 15 ms dead time, 30 Hz mode, drift 5 % of range); the
unmodified recording is the null. Dead times are whole samples (the truth is
``samples / fs``). Creep needs a step followed by a hold or a slow settling: only the piezo
has an input step, the friction tests are smooth tapered sines, so creep runs on the piezo
only (after its one jump the input does not hold: the creep shows as a slow settling of the
cycles, whose look-alike is drift).

Case ids: ``measured/<base>/null`` and ``measured/<base>/<effect>/<size>``.

The development set has a class of the same shape (``dev/measured/<base>/...``,
:data:`DEV_MEASURED_CASES`, :data:`DEV_MEASURED_EFFECTS`): the same recordings with the same
effects at sizes the sealed class does not use (none of its values), so rules for effects on
measured bases can be made and checked without looking at the sealed class. Their nulls are
the same recordings: the gap between the two classes measures how the rules carry to other
effect sizes on a known base, not to other devices.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from benchmarks.diagnosis.generator import Scenario
from benchmarks.diagnosis.output_effects import apply_effect
from core.recordings import Recording

__all__ = ["DEV_MEASURED_CASES", "DEV_MEASURED_EFFECTS", "MEASURED_BASES", "MEASURED_CASES",
           "MEASURED_EFFECTS", "load_base", "make_measured", "truth_of"]

#: Base name -> shipped dataset names diagnosed together.
MEASURED_BASES: dict[str, tuple[str, ...]] = {
    "piezo": ("piezo-150V-1Hz",),
    "friction-30lb": ("friction-0.25Hz-30lb", "friction-1Hz-30lb", "friction-2Hz-30lb"),
    "friction-36lb": ("friction-1Hz-36lb",),
}

_CREEP_TAUS = (0.01, 0.1, 1.0, 10.0)
_FRICTION: dict[str, dict[str, dict[str, Any]]] = {
    "delay": {"issue": {"delay_s": 15e-3}, "third": {"delay_s": 5e-3}},
    "lag": {"large": {"tau_s": 15e-3}, "third": {"tau_s": 5e-3}},
    "resonance": {"issue": {"freq_hz": 30.0, "damping": 0.05},
                  "high": {"freq_hz": 60.0, "damping": 0.05}},
    "drift": {"issue": {"pct": 5.0}, "small": {"pct": 1.5}},
}
#: Base -> effect -> size -> size parameters (delay_s is rounded to whole samples; drift
#: ``pct`` is the ramp over each recording in % of that recording's output range; creep
#: ``total`` is the creeping fraction of a step, split equally over lags at 0.01-10 s).
MEASURED_EFFECTS: dict[str, dict[str, dict[str, dict[str, Any]]]] = {
    "piezo": {
        "delay": {"issue": {"delay_s": 1e-3}, "small": {"delay_s": 0.4e-3}},
        "lag": {"large": {"tau_s": 1e-3}, "small": {"tau_s": 0.3e-3}},
        "resonance": {"issue": {"freq_hz": 350.0, "damping": 0.05},
                      "low": {"freq_hz": 150.0, "damping": 0.05}},
        "drift": {"issue": {"pct": 2.0}, "small": {"pct": 0.7}},
        "creep": {"large": {"total": 0.03}, "small": {"total": 0.01}},
    },
    "friction-30lb": _FRICTION,
    "friction-36lb": _FRICTION,
}

#: Every case of the class, nulls first per base.
MEASURED_CASES: tuple[str, ...] = tuple(
    c for b in MEASURED_BASES for c in (
        f"measured/{b}/null",
        *(f"measured/{b}/{e}/{s}" for e, sizes in MEASURED_EFFECTS[b].items() for s in sizes)))


_DEV_FRICTION: dict[str, dict[str, dict[str, Any]]] = {
    "delay": {"large": {"delay_s": 25e-3}, "small": {"delay_s": 8e-3}},
    "lag": {"large": {"tau_s": 25e-3}, "small": {"tau_s": 8e-3}},
    "resonance": {"low": {"freq_hz": 20.0, "damping": 0.04},
                  "mid": {"freq_hz": 45.0, "damping": 0.04}},
    "drift": {"large": {"pct": 8.0}, "small": {"pct": 3.0}},
}
#: The development class's sizes (same layout as :data:`MEASURED_EFFECTS`; no value of it).
DEV_MEASURED_EFFECTS: dict[str, dict[str, dict[str, dict[str, Any]]]] = {
    "piezo": {
        "delay": {"large": {"delay_s": 2e-3}, "small": {"delay_s": 0.6e-3}},
        "lag": {"large": {"tau_s": 2e-3}, "small": {"tau_s": 0.5e-3}},
        "resonance": {"high": {"freq_hz": 550.0, "damping": 0.04},
                      "low": {"freq_hz": 220.0, "damping": 0.04}},
        "drift": {"large": {"pct": 3.5}, "small": {"pct": 1.2}},
        "creep": {"large": {"total": 0.05}, "small": {"total": 0.02}},
    },
    "friction-30lb": _DEV_FRICTION,
    "friction-36lb": _DEV_FRICTION,
}

#: Every case of the development class, nulls first per base.
DEV_MEASURED_CASES: tuple[str, ...] = tuple(
    c for b in MEASURED_BASES for c in (
        f"dev/measured/{b}/null",
        *(f"dev/measured/{b}/{e}/{s}" for e, sizes in DEV_MEASURED_EFFECTS[b].items()
          for s in sizes)))


def load_base(base: str) -> list[Recording]:
    """The measured recordings of ``base`` (:data:`MEASURED_BASES`), as shipped."""
    from core.datasets import load_dataset

    if base not in MEASURED_BASES:
        raise ValueError(f"unknown measured base {base!r}; known: {', '.join(MEASURED_BASES)}")
    return [load_dataset(n) for n in MEASURED_BASES[base]]


def truth_of(effect: str, size: dict[str, Any], rec: Recording) -> dict[str, Any]:
    """The applied effect's truth parameters on recording ``rec`` (what
    :func:`~benchmarks.diagnosis.output_effects.apply_effect` takes, plus the quantities the
    diagnosis reports: ``delay_s`` of the whole samples, drift ``amount`` in output units)."""
    dt = float(rec.t[1] - rec.t[0])
    if effect == "delay":
        m = int(round(size["delay_s"] / dt))
        return {"samples": m, "delay_s": m * dt}
    if effect == "drift":
        return {"amount": size["pct"] / 100 * float(np.ptp(rec.y)), "pct": size["pct"]}
    if effect == "creep":
        n = len(_CREEP_TAUS)
        return {"taus_s": list(_CREEP_TAUS), "weights": [size["total"] / n] * n}
    return dict(size)


def make_measured(case: str) -> Scenario:
    """The scenario of a case id of :data:`MEASURED_CASES` or :data:`DEV_MEASURED_CASES`
    (also any base/effect/size of their size tables): the base's recordings with the effect
    on their output.

    ``extras``: ``hidden`` (effect -> truth parameters of the first recording, which every
    recording shares except drift's ``amount``), ``base``, ``per_recording`` (the truth of
    each recording), ``size``.
    """
    parts = case.split("/")
    dev = parts[0] == "dev"
    if dev:
        parts = parts[1:]
    if len(parts) not in (3, 4) or parts[0] != "measured":
        raise ValueError(f"a measured case is [dev/]measured/<base>/null or "
                         f"[dev/]measured/<base>/<effect>/<size>, got {case!r}")
    sizes = DEV_MEASURED_EFFECTS if dev else MEASURED_EFFECTS
    base, effect = parts[1], parts[2]
    recs = load_base(base)
    if effect == "null":
        return Scenario(None, "measured", 0, "-", {}, recs, [], 0.0,
                        extras={"hidden": {}, "base": base, "case": case})
    size_name = parts[3] if len(parts) == 4 else ""
    try:
        size = sizes[base][effect][size_name]
    except KeyError:
        raise ValueError(f"unknown measured case {case!r}; known: "
                         f"{', '.join(DEV_MEASURED_CASES if dev else MEASURED_CASES)}") from None
    out, truths = [], []
    for rec in recs:
        tr = truth_of(effect, size, rec)
        y = apply_effect(effect, rec.t, rec.y, tr)
        out.append(Recording(rec.t, rec.u, y, rec.name, units=dict(rec.units)))
        truths.append(tr)
    worst = max(float(np.max(np.abs(r.y - o.y)) / np.ptp(o.y)) for r, o in zip(out, recs,
                                                                              strict=True))
    return Scenario(effect, "measured", 0, size_name, truths[0], out, [], 100 * worst,
                    extras={"hidden": {effect: truths[0]}, "base": base, "case": case,
                            "per_recording": truths, "size": size_name})
