"""The stages that classical PI leaves out, each a registered :class:`~core.base.Model`.

One module per stage family: :mod:`~core.stages.linear` (the discretised filters they
share), :mod:`~core.stages.lag`, :mod:`~core.stages.resonance`, :mod:`~core.stages.delay`,
:mod:`~core.stages.creep`, :mod:`~core.stages.drift`, :mod:`~core.stages.maps` (asymmetry,
offset), :mod:`~core.stages.rate`, :mod:`~core.stages.memory` (initial memory) and
:mod:`~core.stages.preview` (the causal form of a compensator with an advance). The
diagnosis's effects (:mod:`core.diagnosis.effects`) add these stages to a model.

Every effect is a stage of the composition algebra, so a diagnosed model is an ordinary
:class:`~core.base.Chain` that simulates, serialises (``to_dict``/``from_dict``) and is
loaded by :func:`core.base.model_from_dict`. The ``type`` names are the effect names used in
the machine-readable diagnosis output (see ``shared/notes/missing-physics.md`` §3):

============== ============================== =====================================================
type           class                          equation (x = stage input, y = stage output)
============== ============================== =====================================================
delay          :class:`Delay`                 ``y(t) = x(t - τ_d)`` (fractional: interpolated)
lag            :class:`Lag`                   ``τ ẏ + y = x`` (first-order lag, unit DC gain)
resonance      :class:`Resonance`             ``ÿ + 2ζω_n ẏ + ω_n² y = ω_n² x``
rate           :class:`RateDependentPI`       PI whose r > 0 thresholds are ``r_i + β|u̇|``
creep          :class:`Creep`                 ``y = x + Σ_j c_j (L_{τ_j}[x] - x)`` (log-spaced lags)
drift          :class:`Drift`                 ``y = x + Σ_k a_k P_k(2t/T - 1)`` (Legendre in time)
asymmetry      :class:`Asymmetry`             ``y = x + Σ_k a_k ((x - c)/s)^k`` (k = 2, 3, ...)
offset         :class:`Offset`                ``y = x + c``
signed-gain    :class:`SignedGain`            ``y = g+ x`` (x >= 0), ``g- x`` (x < 0)
initial-memory :class:`InitialMemory`         hysteresis model started after a virtual input history
============== ============================== =====================================================

Linear dynamics are discretised exactly for a piecewise-linear input (first-order hold), so
they have unit DC gain and the default state is "at rest at the first input sample".

Every effect inverts (``inverse()``), exactly where the physics allows:

============== ========================== ========================================================
effect         inverse                    how, and what is exact
============== ========================== ========================================================
offset, drift  the same, negated          exact (drift as a function of time)
signed-gain    the same, ``1/g+, 1/g-``   exact (monotone, zero kept at zero)
lag            :class:`LagInverse`        exact inverse of the discretised lag (per-sample solve)
creep          :class:`CreepInverse`      exact inverse of the minimum-phase discrete operator
resonance      :class:`ResonanceInverse`  mode cancelled, 3rd-order roll-off at ``bandwidth_hz``;
                                          error ``<= 3 max|ÿ| / (2π f_c)²``
asymmetry      :class:`AsymmetryInverse`  bisection on the monotone range, clipped (warning) outside
rate           :class:`RateDependentPIInverse` per-sample bisection, tolerance ≈ 1e-15 relative
initial-memory inverse PI / rate inverse  started in the consistent state
delay          :class:`Advance`           non-causal: needs ``preview_samples(dt)`` samples ahead;
                                          :func:`causal_form` gives the real-time compensator
============== ========================== ========================================================
"""

from __future__ import annotations

from .creep import Creep, CreepInverse
from .delay import Advance, Delay, delay_split
from .drift import Drift
from .lag import Lag, LagInverse
from .linear import LagBank, discretised_tf, foh_filter
from .maps import Asymmetry, AsymmetryInverse, Offset, SignedGain, bisect_steps
from .memory import InitialMemory
from .preview import CausalForm, causal_form
from .rate import RateDependentPI, RateDependentPIInverse, rd_play_bank
from .resonance import Resonance, ResonanceInverse

__all__ = [
    "Advance",
    "Asymmetry",
    "AsymmetryInverse",
    "CausalForm",
    "Creep",
    "CreepInverse",
    "Delay",
    "Drift",
    "InitialMemory",
    "Lag",
    "LagBank",
    "LagInverse",
    "Offset",
    "RateDependentPI",
    "RateDependentPIInverse",
    "Resonance",
    "ResonanceInverse",
    "SignedGain",
    "bisect_steps",
    "causal_form",
    "delay_split",
    "discretised_tf",
    "foh_filter",
    "rd_play_bank",
]
