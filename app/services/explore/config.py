"""The explorer's config: the immutable value that determines a session's plots.

:class:`Config` (model, input signal, mismatch, input source) is replaced as a whole,
never mutated; :class:`SignalSpec` is its input signal. No viser / fastapi / plotly imports.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from typing import Any, TypedDict

import numpy as np

from core.exceptions import ParameterError
from core.signals import SIGNALS

__all__ = ["CONTROLS", "EXAMPLE1", "Config", "ConfigDoc", "ControlRange", "SignalDoc",
           "SignalSpec", "config_from_dict"]


@dataclass(frozen=True)
class ControlRange:
    """The range of one slider of the explorer's input and inverse controls.

    Parameters
    ----------
    label : str
        The slider's label.
    low, high : float
        Its ends (inclusive).
    step : float
        Its step.
    unit : str
        The unit shown after the value (``""``: the input's own unit).
    """

    label: str
    low: float
    high: float
    step: float
    unit: str = ""

    def problem(self, value: Any, path: str) -> str | None:
        """Why ``value`` at ``path`` cannot be set on this slider, or ``None``."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            try:
                shown = json.dumps(value)[:40]
            except (TypeError, ValueError):
                shown = type(value).__name__
            return f"{path} must be a number, got {shown}"
        if not self.low <= value <= self.high:  # also refuses nan
            unit = f" {self.unit}" if self.unit else ""
            return (f"{path} is {value:g}{unit}, outside the {self.label} slider's range "
                    f"{self.low:g} to {self.high:g}{unit}; choose a value in it")
        return None


#: The sliders of the input signal and the mismatch (the viser GUI builds them from here;
#: a lesson's steps are checked against them, so a step can be shown on them).
CONTROLS: dict[str, ControlRange] = {
    "amplitude": ControlRange("Amplitude", 0.0, 10.0, 0.05),
    "frequency": ControlRange("Frequency", 0.1, 20.0, 0.1, "Hz"),
    "offset": ControlRange("Offset", -5.0, 5.0, 0.05),
    "duration": ControlRange("Duration", 0.5, 20.0, 0.5, "s"),
    "mismatch": ControlRange("Model mismatch", -0.5, 0.5, 0.01),
}

#: Paper 001 Example 1: r_i = 0.45 i, p0 = 0.72, p = (0.6, 0.48, 0.36, 0.24, 0.12, 0.012).
EXAMPLE1: dict[str, Any] = {
    "type": "pi",
    "p0": 0.72,
    "thresholds": [0.45, 0.9, 1.35, 1.8, 2.25, 2.7],
    "weights": [0.6, 0.48, 0.36, 0.24, 0.12, 0.012],
}

class SignalDoc(TypedDict):
    """:class:`SignalSpec` as JSON: its fields, in their order."""

    kind: str
    amplitude: float
    frequency: float
    offset: float
    duration: float
    samples: int


class ConfigDoc(TypedDict):
    """:class:`Config` as JSON (:meth:`Config.to_dict`, read back by
    :func:`config_from_dict`); ``model`` is a model document of any registered type."""

    model: dict[str, Any]
    signal: SignalDoc
    mismatch: float
    use_recording: bool


@dataclass(frozen=True)
class SignalSpec:
    """An input signal ``offset + amplitude * shape(frequency * t)`` on ``[0, duration]``.

    Parameters
    ----------
    kind : str
        Shape name, a key of :data:`core.signals.SIGNALS`.
    amplitude : float
        Peak value, input units.
    frequency : float
        Fundamental frequency, Hz.
    offset : float
        Added constant, input units.
    duration : float
        Length, s.
    samples : int
        Number of samples (uniform spacing ``duration / (samples - 1)``).
    """

    kind: str = "sine"
    amplitude: float = 4.0
    frequency: float = 1.0
    offset: float = 0.0
    duration: float = 2.0
    samples: int = 2000

    def to_dict(self) -> SignalDoc:
        """JSON-ready form: the fields, in their order."""
        return {"kind": self.kind, "amplitude": self.amplitude, "frequency": self.frequency,
                "offset": self.offset, "duration": self.duration, "samples": self.samples}

    def validate(self, max_samples: int) -> None:
        """Raise :class:`ParameterError` naming the first field out of range."""
        if self.kind not in SIGNALS:
            raise ParameterError(
                f"signal.kind {self.kind!r} unknown; known: {', '.join(SIGNALS)}"
            )
        for name in ("amplitude", "frequency", "offset", "duration"):
            if not np.isfinite(getattr(self, name)):
                raise ParameterError(f"signal.{name} must be finite")
        if self.duration <= 0:
            raise ParameterError(f"signal.duration must be > 0 s, got {self.duration:g}")
        if self.frequency < 0:
            raise ParameterError(f"signal.frequency must be >= 0 Hz, got {self.frequency:g}")
        if not 2 <= self.samples <= max_samples:
            raise ParameterError(
                f"signal.samples must be between 2 and {max_samples}, got {self.samples}"
            )


@dataclass(frozen=True, eq=False)
class Config:
    """Everything that determines the plots of one session (replace, never mutate).

    Parameters
    ----------
    model : dict
        The model's ``to_dict()`` form (any registered type).
    signal : SignalSpec
        The input signal.
    mismatch : float
        Relative plant perturbation for the inverse-compensation view, see
        :func:`app.services.explore.simulation.perturb`.
    use_recording : bool
        Drive the model with the uploaded recording's input instead of ``signal``.
    """

    model: dict[str, Any] = field(default_factory=lambda: dict(EXAMPLE1))
    signal: SignalSpec = field(default_factory=SignalSpec)
    mismatch: float = 0.0
    use_recording: bool = False

    def with_model(self, model: dict[str, Any]) -> Config:
        """Copy with another model."""
        return replace(self, model=dict(model))

    def to_dict(self) -> ConfigDoc:
        """JSON-ready form."""
        return {
            "model": self.model,
            "signal": self.signal.to_dict(),
            "mismatch": self.mismatch,
            "use_recording": self.use_recording,
        }


def config_from_dict(d: dict[str, Any]) -> Config:
    """Inverse of :meth:`Config.to_dict` (a stored config)."""
    return Config(model=dict(d["model"]), signal=SignalSpec(**d["signal"]),
                  mismatch=float(d["mismatch"]), use_recording=bool(d["use_recording"]))
