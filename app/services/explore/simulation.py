"""Simulation of an explorer config: model, signal, inverse, digitized and closed loop.

:func:`compute` turns a :class:`~app.services.explore.config.Config` into a :class:`Result` with
everything the figures of the requested views need, and nothing for the views not on show
(the inverse, the perturbed plant, the digitized trace and state graph, the operator
contributions, the loading curve and paper 001's closed loop are each computed only for
their view); :mod:`.figures` only draws a result. No viser / fastapi / plotly imports.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Collection
from dataclasses import dataclass, field, replace
from typing import Any, TypedDict

import numpy as np

from app.services.explore.config import Config, SignalDoc, SignalSpec
from app.services.explore.cost import priced_run, priced_steps
from app.services.words import type_words
from core.base import Chain, Model, RunCost, model_from_dict
from core.closed_loop import ClosedLoopResult, HammersteinLoop, paper001_plant
from core.digitized import DigitizedPI
from core.exceptions import ClippedInputWarning, NotInvertibleError, ParameterError
from core.fitting.thresholds import reversal_indices
from core.operators import play_bank
from core.pi import PIModel
from core.presets import get_preset, list_presets
from core.recordings import Recording
from core.signals import SIGNALS

__all__ = [
    "CLOSED_LOOP_MAX_S",
    "FULL_GRAPH_DIGITS",
    "MAX_GRAPH_DIGITS",
    "VIEWS",
    "ClosedLoop",
    "Digitized",
    "Loading",
    "Result",
    "build_model",
    "check_operator_limit",
    "closed_loop",
    "compute",
    "decimate_index",
    "inverse_problem",
    "make_signal",
    "operator_contributions",
    "perturb",
    "pi_input",
    "pi_part",
    "PresetDoc",
    "preset_doc",
    "preset_input",
    "priced_views",
    "state_text",
    "visited_path",
]


def make_signal(spec: SignalSpec) -> tuple[np.ndarray, np.ndarray]:
    """Sample times ``t`` (s) and input ``u`` of ``spec``.

    The :data:`core.signals.SIGNALS` generator is called with the parameters it accepts
    (``amplitude``, ``frequency``/``f0``, ``offset``, ``duration`` and the sample rate
    ``(samples - 1) / duration``); signals without a duration (staircase) choose their own
    length.
    """
    gen = SIGNALS[spec.kind]
    names = {p.name for p in gen.params}
    kw: dict[str, float] = {"sample_rate": (spec.samples - 1) / spec.duration}
    for key in ("amplitude", "frequency", "offset", "duration"):
        kw[key] = getattr(spec, key)
    if "frequency" not in names:
        kw["f0"] = spec.frequency
    t, u = gen.build(**{k: v for k, v in kw.items() if k in names})
    return np.asarray(t, dtype=np.float64), np.asarray(u, dtype=np.float64)


def preset_input(model: Model) -> SignalSpec:
    """The input signal that suits ``model`` when it is loaded as a preset.

    A digitized PI (paper 000) is driven across its whole loop: its digits flip between
    ``x0`` and ``x0 + Σ Δx``, so the sine spans that interval with a 10 % margin on each
    side (paper 000's three-operator example: 0…10). Every other preset keeps the default
    ±4 sine of paper 001 Example 1.
    """
    if isinstance(model, DigitizedPI):
        lo = float(model.x0)
        hi = lo + float(np.sum(model.dx))
        span = hi - lo
        return SignalSpec(amplitude=round(0.55 * span, 3), offset=round(0.5 * (lo + hi), 3))
    return SignalSpec()


class PresetDoc(TypedDict):
    """A preset as the menus and ``GET /api/presets`` list it (:func:`preset_doc`)."""

    name: str
    title: str
    description: str
    #: the preset's model document
    model: dict[str, Any]
    #: the :func:`preset_input` signal that suits it
    input: SignalDoc


def preset_doc(name: str) -> PresetDoc:
    """The :class:`PresetDoc` of the preset ``name``.

    ``input`` is the :func:`preset_input` signal as JSON (the fields of
    :class:`~app.services.explore.config.SignalSpec`).

    Raises
    ------
    ParameterError
        If ``name`` is unknown (the message lists the valid names).
    """
    m = get_preset(name)
    info = next(p for p in list_presets() if p.name == name)
    return {"name": name, "title": info.title, "description": info.description,
            "model": m.to_dict(), "input": preset_input(m).to_dict()}


def build_model(d: dict[str, Any], max_operators: int) -> Model:
    """Validated model from its dict form, enforcing the operator limit."""
    return check_operator_limit(model_from_dict(d), max_operators)


def check_operator_limit(m: Model, max_operators: int) -> Model:
    """``m``, after checking its :func:`operator_count` against ``max_operators``."""
    n = operator_count(m)
    if n is not None and n > max_operators:
        raise ParameterError(
            f"model has {n} operators; the explorer allows at most {max_operators}"
        )
    return m


def operator_count(model: Model) -> int | None:
    """Hysteresis operators (plays or digits) in ``model`` and its stages; ``None`` if none."""
    n = getattr(model, "n", None)
    if isinstance(n, int):
        return n
    counts = [c for st in getattr(model, "stages", ()) if (c := operator_count(st)) is not None]
    return sum(counts) if counts else None


def pi_part(model: Model) -> PIModel | None:
    """The classical PI model inside ``model`` (itself, or a chain stage), else ``None``."""
    if isinstance(model, PIModel):
        return model
    stages = getattr(model, "stages", ())
    for st in stages:
        if isinstance(st, PIModel):
            return st
    return None


def weight_note(model: Model) -> str | None:
    """What a negative play weight of ``model``'s classical PI does, in words (its slope
    after the threshold drops; the model inverts while every slope stays > 0), or ``None``
    when no weight is negative."""
    pi = pi_part(model)
    if pi is None:
        return None
    neg = [i for i, w in enumerate(pi.weights) if w < 0]
    if not neg:
        return None
    s = pi.slopes
    which = ", ".join(f"p{i + 1} = {pi.weights[i]:.3g}" for i in neg[:4])
    head = (f"Negative weight{'s' if len(neg) > 1 else ''} {which}: past its threshold the "
            f"loop's slope drops by that much (slopes {s.min():.3g} to {s.max():.3g}); ")
    if pi.is_invertible:
        return head + ("the model stays invertible while every slope stays above 0 (the "
                       f"smallest is {s.min():.3g} now); a slope at or below 0 leaves it "
                       "without an inverse.")
    return head + (f"a slope is {s.min():.3g}, at or below 0, so the model has no inverse "
                   "(no compensation): raise p0 or the weights before it.")


def pi_input(model: Model, u: np.ndarray, dt: float | None = None) -> np.ndarray:
    """The signal that drives the classical PI inside ``model``.

    For a bare PI that is ``u``; for a chain or a generalized PI whose stages put a map
    before the PI (the dead-zone GPI's ``γ``, a tanh envelope), it is the output of those
    stages, so the operators can be stacked on what they really see.
    """
    stages = getattr(model, "stages", ())
    w = u
    for st in stages:
        if isinstance(st, PIModel):
            return w
        w = st.simulate(w, dt=dt).y
    return u


def perturb(model: Model, mismatch: float) -> Model:
    """The "real plant" used against an inverse built from ``model``.

    Thresholds are scaled by ``1 + mismatch`` and the play weights by ``1 - mismatch``
    (``p0`` is kept), so ``mismatch = 0`` returns ``model`` and ``±0.2`` gives a plant whose
    loop is visibly wider or narrower than the model's. Non-PI models are returned as is.
    """
    if mismatch == 0:
        return model
    if isinstance(model, Chain):
        return Chain(tuple(perturb(st, mismatch) for st in model.stages))
    if not isinstance(model, PIModel):
        return model
    return PIModel(
        model.p0, model.thresholds * (1 + mismatch), model.weights * (1 - mismatch), model.state0
    )


#: Largest number of digits the digitized view builds a state graph for (2**n states).
MAX_GRAPH_DIGITS = 10


#: Largest number of digits whose whole state graph (``2**n`` states) is drawn; beyond, the
#: views draw the states the input visited (a projected 4-cube or more is a tangle).
FULL_GRAPH_DIGITS = 3


def visited_path(digits: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The states a trace visited and the transitions it made.

    Parameters
    ----------
    digits : ndarray of shape (rows, n)
        The trace's digit rows (``b_1 … b_n``), in time order.

    Returns
    -------
    states : ndarray of shape (k, n)
        Each visited state once, in order of its first visit.
    up, down : ndarray of shape (m, 2)
        Indices into ``states`` of each distinct transition that set digits (the input
        rose) or cleared them (it fell).
    first : ndarray of shape (k,)
        The trace row of each state's first visit.
    """
    rows = np.asarray(digits, dtype=np.int8)
    index: dict[bytes, int] = {}
    order: list[Any] = []
    first: list[Any] = []
    for i, r in enumerate(rows):
        key = r.tobytes()
        if key not in index:
            index[key] = len(order)
            order.append(r)
            first.append(i)
    seq = [index[r.tobytes()] for r in rows]
    up: set[Any] = set()
    down: set[Any] = set()
    for a, b in zip(seq[:-1], seq[1:], strict=True):
        if a != b:
            (up if _set_digits(order[b]) > _set_digits(order[a]) else down).add((a, b))
    pair = lambda s: np.array(sorted(s), dtype=int).reshape(-1, 2)  # noqa: E731
    n = rows.shape[1] if rows.ndim == 2 else 0
    return (np.array(order, dtype=np.int8).reshape(-1, n), pair(up), pair(down),
            np.array(first, dtype=int))


def _set_digits(row: np.ndarray) -> int:
    """Number of set digits of a state."""
    return int(np.sum(row))


def state_text(row: np.ndarray) -> str:
    """A state in the paper's notation ``b_n … b_1``."""
    return "".join(str(int(b)) for b in row[::-1])


@dataclass(frozen=True, eq=False)
class Digitized:
    """Digitized (binary-state) view of the run (paper 000).

    Attributes
    ----------
    model : DigitizedPI
        The digitized model (``H = [dx; dy]``, origin ``(x0, y0)``).
    trace : DigitizedTrace
        States visited by the input (digit rows, sample index of each state).
    graph : StateGraph or None
        All ``2**n`` states and their edges (``None`` beyond :data:`MAX_GRAPH_DIGITS`).
    y : ndarray of shape (N,)
        Digitized output.
    y_classical : ndarray of shape (N,)
        The equivalent classical PI (:meth:`DigitizedPI.to_pi`) on the same input.
    """

    model: Any
    trace: Any
    graph: Any
    y: np.ndarray
    y_classical: np.ndarray

    @property
    def H(self) -> np.ndarray:  # noqa: N802 - the paper's name
        """Paired properties ``[Δx; Δy]``, shape ``(2, n)``."""
        return np.vstack((self.model.dx, self.model.dy))

    def state_at(self, k: int) -> int:
        """Index of the trace row active at sample ``k``."""
        return int(np.searchsorted(self.trace.sample, k, side="right") - 1)


def digitize(model: Model, u: np.ndarray) -> tuple[Digitized | None, str | None]:
    """The digitized view of ``model`` driven by ``u``, or ``(None, reason)``."""
    if isinstance(model, DigitizedPI):
        dig = model
    else:
        pi = pi_part(model)
        if pi is None:
            return None, "the digitized view needs a classical PI (or digitized) model"
        stages = getattr(model, "stages", ())
        if stages and stages[0] is not pi:  # a GPI: the operators see a mapped input
            return None, (
                f"the digitized view (paper 000) is for a classical PI; this "
                f"{type_words(model.type_name).lower()} maps the input before its operators, "
                "so its states are not a digitized PI's")
        lo, hi = float(np.min(u)), float(np.max(u))
        if 0.5 * (hi - lo) <= pi.thresholds[-1]:
            return None, (
                f"the input's half span {0.5 * (hi - lo):.3g} must exceed the largest "
                f"threshold {pi.thresholds[-1]:.3g}: raise the amplitude"
            )
        dig = DigitizedPI.from_pi(pi, (lo, hi))
    tr = dig.trace(u)
    graph = dig.state_graph() if dig.n <= MAX_GRAPH_DIGITS else None
    y_cl = dig.to_pi().simulate(u).y + float(dig.classical_offset)
    return Digitized(dig, tr, graph, np.asarray(tr.y), y_cl), None


@dataclass(frozen=True, eq=False)
class Loading:
    """The initial loading curve ``φ(r)`` of a classical PI (paper 001, eq. 22).

    Attributes
    ----------
    knots : ndarray of shape (K,)
        ``0``, the thresholds below ``r_max`` and ``r_max``, input units.
    phi : ndarray of shape (K,)
        ``φ`` at the knots, output units.
    slopes : ndarray of shape (n,)
        Slope of each segment.
    max_loop_width : float
        Widest loop ``σ``, output units.
    invertible : bool
        Every slope positive.
    curve_u, curve_y : ndarray of shape (201,)
        The curve over ``[-|u|max, |u|max]`` (the loop view's overlay), ``y = φ`` odd
        extension; ``None`` when the PI is a stage of a larger model.
    """

    knots: np.ndarray
    phi: np.ndarray
    slopes: np.ndarray
    max_loop_width: float
    invertible: bool
    curve_u: np.ndarray | None = None
    curve_y: np.ndarray | None = None


def loading(model: Model, u_max: float | None) -> Loading | None:
    """The :class:`Loading` of ``model``'s classical PI up to ``u_max`` (default: 1.25 times
    the widest threshold), or ``None`` when it has none."""
    pi = pi_part(model)
    if pi is None:
        return None
    rmax = float(u_max or 1.25 * pi.thresholds[-1])
    knots = np.concatenate(([0.0], pi.thresholds[pi.thresholds < rmax], [rmax]))
    cu = cy = None
    if pi is model:
        cu = np.linspace(-(u_max or 1.0), u_max or 1.0, 201)
        cy = pi.loading_curve(cu)
    return Loading(knots, pi.loading_curve(knots), pi.slopes, float(pi.max_loop_width),
                   bool(pi.is_invertible), cu, cy)


#: The views (figures) a result can be computed for.
VIEWS = ("time", "loop", "operators", "loading", "inverse", "digitized", "closed-loop")


@dataclass(frozen=True, eq=False)
class Result:
    """Everything the figures show for one config (arrays of shape ``(N,)`` unless noted)."""

    version: int
    model: Model
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    contributions: np.ndarray | None = None  # (M, n): p_i * Γ_{r_i}[u] at contrib_idx
    contrib_idx: np.ndarray | None = None  # (M,) sample indices of the contribution rows
    v: np.ndarray | None = None  # inverse's output (plant input) for desired output u
    y_comp: np.ndarray | None = None  # plant(v): compensated output
    inverse_error: str | None = None
    #: The diagnosed (extended) model the inverse and closed-loop views compensate, if any.
    diagnosed: Model | None = None
    y_measured: np.ndarray | None = None
    digitized: Digitized | None = None
    messages: tuple[str, ...] = ()
    elapsed_ms: float = 0.0
    pi_u: np.ndarray | None = None  # (N,) input of the PI stage (u unless a map precedes it)
    pi_y: np.ndarray | None = None  # (N,) output of the PI stage when a map follows it
    inverse_warning: str | None = None  # the inverse ran but clipped part of the input
    units: dict[str, str] = field(default_factory=dict)  # "time", "input", "output"
    loading: Loading | None = None  # the PI's loading curve (loop and loading views)
    closed_loop: ClosedLoop | None = None  # paper 001's closed loop (its view only)
    closed_loop_note: str | None = None  # why it is missing, or what it is limited to
    mismatch: float = 0.0  # the config's plant mismatch
    views: frozenset[str] = frozenset()  # the views this result was computed for


def decimate_index(u: np.ndarray, max_points: int = 800) -> np.ndarray:
    """Indices of at most about ``max_points`` samples, always keeping input reversals.

    Parameters
    ----------
    u : ndarray of shape (N,)
        The input whose turning points must survive (loop corners).
    max_points : int
        Target number of points.

    Returns
    -------
    ndarray of int
        Sorted unique indices including ``0`` and ``N - 1``.
    """
    n = int(u.size)
    if n <= max_points:
        return np.arange(n)
    stride = int(np.ceil(n / max_points))
    base = np.arange(0, n, stride)
    turns = reversal_indices(u, 0.0)
    if turns.size > max_points // 2:
        turns = turns[:: int(np.ceil(2 * turns.size / max_points))]
    return np.unique(np.concatenate((base, turns, [n - 1])))


#: Rows of the operator-contribution matrix kept for the stacked plot.
CONTRIB_ROWS = 300
#: Samples per chunk when the play-operator matrix is computed piecewise.
CONTRIB_CHUNK = 20_000


def operator_contributions(pi: PIModel, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``p_i Γ_{r_i}[u]`` at about :data:`CONTRIB_ROWS` samples (reversals kept).

    The play states are carried from chunk to chunk, so memory stays at
    ``CONTRIB_CHUNK × n`` floats whatever the signal length.

    Returns
    -------
    idx : ndarray of int, shape (M,)
        Sample indices.
    contrib : ndarray of shape (M, n)
    """
    idx = decimate_index(u, CONTRIB_ROWS)
    out = np.empty((idx.size, pi.n))
    z = np.array(pi.state0, dtype=np.float64)
    for start in range(0, u.size, CONTRIB_CHUNK):
        stop = min(u.size, start + CONTRIB_CHUNK)
        Y, z = play_bank(u[start:stop], pi.thresholds, z)
        sel = (idx >= start) & (idx < stop)
        out[sel] = Y[idx[sel] - start]
    return idx, out * pi.weights


def compute(
    config: Config,
    *,
    views: Collection[str] = VIEWS,
    version: int = 0,
    recording: Recording | None = None,
    max_operators: int = 100,
    max_samples: int = 200_000,
    diagnosed: Model | None = None,
    model: Model | None = None,
) -> Result:
    """Simulate ``config`` and compute what the figures of ``views`` need.

    ``views`` (names of :data:`VIEWS`; all by default) selects the work beyond the
    model's output: the inverse-compensation run and the perturbed plant (``"inverse"``),
    the digitized trace and state graph (``"digitized"``), the operator contributions
    (``"operators"``), the loading curve (``"loop"``, ``"loading"``) and paper 001's
    closed loop (``"closed-loop"``). An inverse that had to clip part of its input (a
    tanh envelope's bounded domain) still runs; ``Result.inverse_warning`` says so.
    ``diagnosed`` (the session's diagnosed extended model, :func:`diagnosed_model`) is the
    model the inverse and closed-loop views then compensate instead of the config's model.
    ``model`` is the config's model when the caller has built and checked it already (a
    session keeps it, :meth:`~app.services.session.sessions.Session.checked`); it is then not
    parsed again.

    Raises
    ------
    ParameterError
        If the model or the signal is invalid (the message names the field).
    """
    views = frozenset(views)
    with_inverse = "inverse" in views
    with_digitized = "digitized" in views
    with_operators = "operators" in views
    t0 = time.perf_counter()
    model = build_model(config.model, max_operators) if model is None else model
    y_meas = None
    units = {"time": "s", "input": "", "output": ""}
    if config.use_recording and recording is not None:
        t, u, y_meas = recording.t, recording.u, recording.y
        units.update({k: v for k, v in recording.units.items() if v})
    else:
        config.signal.validate(max_samples)
        t, u = make_signal(config.signal)
    dt = float(t[1] - t[0]) if t.size > 1 else None
    if u.size > max_samples:
        raise ParameterError(f"the input has {u.size} samples; at most {max_samples} allowed")
    y = model.simulate(u, dt=dt).y
    contrib = contrib_idx = w = pi_y = None
    pi = pi_part(model)
    if pi is not None and with_operators:
        w = pi_input(model, u, dt)
        contrib_idx, contrib = operator_contributions(pi, w)
        stages = getattr(model, "stages", ())
        if stages and stages[-1] is not pi:  # a map after the PI: the stack is its output
            pi_y = pi.simulate(w).y
    v = y_comp = None
    inv_err = inv_warn = None
    if with_inverse:
        comp = model if diagnosed is None else diagnosed
        try:
            inv = comp.inverse()
            # desired output = the signal; plant input v = P^-1(u); plant output P~(v)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", ClippedInputWarning)
                v = inv.simulate(u, dt=dt).y
            clipped = [str(c.message) for c in caught
                       if issubclass(c.category, ClippedInputWarning)]
            if clipped:
                inv_warn = clipped[0]
            y_comp = perturb(comp, config.mismatch).simulate(v, dt=dt).y
        except NotInvertibleError as exc:
            inv_err = str(exc)
        except ValueError as exc:  # e.g. an input outside an inverse's domain
            inv_err = f"inverse unavailable: {exc}"
    digi, digi_msg = None, None
    try:
        if with_digitized:
            digi, digi_msg = digitize(model, u)
    except (ParameterError, ValueError) as exc:
        digi_msg = f"digitized view unavailable: {exc}"
    res = Result(
        version=version,
        model=model,
        digitized=digi,
        messages=(digi_msg,) if digi_msg else (),
        t=t,
        u=u,
        y=y,
        contributions=contrib,
        contrib_idx=contrib_idx,
        pi_u=w,
        pi_y=pi_y,
        v=v,
        y_comp=y_comp,
        inverse_error=inv_err,
        diagnosed=diagnosed,
        inverse_warning=inv_warn,
        units=units,
        y_measured=y_meas,
        mismatch=float(config.mismatch),
        views=views,
        loading=(loading(model, float(np.max(np.abs(u))) or None)
                 if views & {"loop", "loading"} else None),
    )
    if "closed-loop" in views:
        cl, note = closed_loop(res, config.mismatch)
        res = replace(res, closed_loop=cl, closed_loop_note=note)
    return replace(res, elapsed_ms=1e3 * (time.perf_counter() - t0))


# ----------------------------------------------------------------------------- closed loop
#: Sample rate of the closed-loop runs (paper 001's plant has poles near 3-4 kHz).
CLOSED_LOOP_RATE = 50_000.0
#: Longest closed-loop run, s (50,000 samples at 50 kHz: one period of the 1 Hz default).
CLOSED_LOOP_MAX_S = 1.0
#: Longest closed-loop run of a diagnosed (extended) model, s.
DIAGNOSED_LOOP_MAX_S = 0.02


def priced_views(model: Model, views: Collection[str], samples: int, dt: float,
                 diagnosed: Model | None = None) -> RunCost:
    """Priced work and memory of what :func:`compute` runs for ``views`` beyond the model's
    own run (which :func:`app.services.explore.cost.check_model` prices), from the declared costs
    of the models that run (:meth:`core.base.Model.cost`):

    - ``"inverse"``: the inverse of the compensated model (``diagnosed`` when given, else
      ``model``; each inverse type declares its own cost) and the perturbed plant, on
      ``samples`` samples;
    - ``"closed-loop"`` of a ``diagnosed`` chain: the plant four times and its inverse three
      times, one sample per call (:func:`app.services.explore.cost.priced_steps`) over
      :data:`DIAGNOSED_LOOP_MAX_S` (the compiled loop of a classical PI model costs about
      as much as its own run, and nothing else has a closed loop).

    An inverse that cannot be built costs nothing (the view says why).
    """
    views = frozenset(views)
    total = RunCost(0.0, 0.0)
    comp = model if diagnosed is None else diagnosed
    inv = None
    if views & {"inverse", "closed-loop"}:
        try:
            inv = comp.inverse()
        except (NotInvertibleError, ValueError):
            inv = None
    if "inverse" in views and inv is not None:
        total = total + priced_run(inv, samples, dt) + priced_run(comp, samples, dt)
    if "closed-loop" in views and diagnosed is not None:
        steps = int(round(DIAGNOSED_LOOP_MAX_S * CLOSED_LOOP_RATE))
        dt_loop = 1.0 / CLOSED_LOOP_RATE
        plant = priced_steps(diagnosed, steps, dt_loop)
        total = total + RunCost(4.0 * plant.work, plant.memory)
        if inv is not None:
            ff = priced_steps(inv, steps, dt_loop)
            total = total + RunCost(3.0 * ff.work, ff.memory)
    return total


def diagnosed_model(session: Any) -> Model | None:
    """The session's diagnosed extended model when the diagnosis added effects, else None
    (:attr:`~app.services.session.sessions.Session.diagnosed`: the live result's model,
    or after a restart the stored one)."""
    model = getattr(session, "diagnosed", None)
    return model if isinstance(model, Model) else None


@dataclass(frozen=True, eq=False)
class ClosedLoop:
    """Paper 001 Fig. 15-16: PI controller + ``G(s)`` (eq. 38) around the hysteresis.

    Attributes
    ----------
    runs : dict
        ``{"no compensation": ClosedLoopResult, "inverse feedforward": ...,
        "inverse + reference feedforward": ...}``; the plant's hysteresis is the
        (mismatch-perturbed) session model, the feedforward is the exact inverse of the
        unperturbed model; the last run adds the reference to the controller output
        (two-degree-of-freedom structure, not in the paper's Fig. 15).
    explanation : str or None
        Why the inverse feedforward tracks worse than no compensation, when it does (in
        words, with the numbers that show it); ``None`` otherwise.
    """

    runs: dict[str, ClosedLoopResult]
    explanation: str | None = None


def closed_loop(res: Result, mismatch: float) -> tuple[ClosedLoop | None, str | None]:
    """Closed-loop runs of ``res``'s model (the diagnosed one when the session holds it)
    tracking ``res.u`` as the reference."""
    pi = res.diagnosed if res.diagnosed is not None else (
        res.model if isinstance(res.model, PIModel) else None)
    if pi is None:
        return None, "the closed loop is simulated for classical PI and diagnosed models only"
    # a diagnosed chain runs sample by sample in Python: a shorter run
    dur = min(float(res.t[-1] - res.t[0]),
              CLOSED_LOOP_MAX_S if isinstance(pi, PIModel) else DIAGNOSED_LOOP_MAX_S)
    tt = np.arange(0.0, dur, 1.0 / CLOSED_LOOP_RATE)
    r = np.interp(tt + res.t[0], res.t, res.u)
    plant_h = perturb(pi, mismatch)
    runs: dict[str, ClosedLoopResult] = {}
    g = paper001_plant()
    runs["no compensation"] = HammersteinLoop(plant_h, g).simulate(r, 1.0 / CLOSED_LOOP_RATE)
    try:
        ff = pi.inverse()
    except NotInvertibleError as exc:
        return ClosedLoop(runs), f"no inverse feedforward: {exc}"
    runs["inverse feedforward"] = HammersteinLoop(plant_h, g, feedforward=ff).simulate(
        r, 1.0 / CLOSED_LOOP_RATE)
    runs["inverse + reference feedforward"] = HammersteinLoop(
        plant_h, g, feedforward=ff, reference_feedforward=True).simulate(r, 1.0 / CLOSED_LOOP_RATE)
    note = None if isinstance(pi, PIModel) else (
        f"closed loop of the diagnosed model over its first {1e3 * dur:g} ms (its effects run "
        "sample by sample)")
    why = None
    if runs["inverse feedforward"].rms_error(0.0) > runs["no compensation"].rms_error(0.0):
        perfect = None
        if mismatch != 0:  # the same loop with the plant exactly the model: mismatch's share
            perfect = HammersteinLoop(pi, g, feedforward=ff).simulate(
                r, 1.0 / CLOSED_LOOP_RATE).rms_error(0.0)
        why = feedforward_worse(runs, mismatch, perfect, pi_part(pi))
    return ClosedLoop(runs, why), note


def feedforward_worse(runs: dict[str, ClosedLoopResult], mismatch: float, perfect: float | None,
                      pi: PIModel | None) -> str:
    """Why the inverse feedforward tracks worse than no compensation, in words.

    Two causes, each with its number: a model mismatch (the plant is not the model the
    inverse was built from; ``perfect`` is the RMS error of the same loop with the plant
    exactly the model) and the loop gain the inverse takes away (the model's slopes, for
    which the PI controller was tuned, become 1); the reference feedforward run shows the
    lag removed."""
    ff = runs["inverse feedforward"].rms_error(0.0)
    none = runs["no compensation"].rms_error(0.0)
    both = runs["inverse + reference feedforward"].rms_error(0.0)
    text = (f"Why does the inverse feedforward do worse here (RMS error {ff:.3g}) than no "
            f"compensation ({none:.3g})? ")
    if mismatch != 0 and perfect is not None:
        text += (f"Partly a model mismatch: the plant differs from the model the inverse was "
                 f"built from (thresholds ×{1 + mismatch:.2f}, weights ×{1 - mismatch:.2f}), "
                 f"so the inverse cancels a hysteresis that is not quite there; with the plant "
                 f"exactly the model it would reach {perfect:.3g}. ")
    gain = ""
    if pi is not None and pi.slopes.size:
        gain = (f" (the model's slopes run from {float(np.min(pi.slopes)):.3g} to "
                f"{float(np.max(pi.slopes)):.3g}; after the inverse the plant's gain is 1)")
    text += ("The inverse also removes the model's own gain" + gain + ", and the PI "
             "controller was tuned for the plant with it: the loop is slower and lags the "
             f"reference. Adding the reference as feedforward removes that lag (RMS {both:.3g}).")
    return text


def inverse_problem(res: Result) -> str | None:
    """Why ``res``'s model has no usable inverse, or ``None``; without the inverse view
    computed, only whether the inverse can be built (nothing is simulated)."""
    if res.inverse_error is not None or "inverse" in res.views:
        return res.inverse_error
    try:
        res.model.inverse()
    except (NotInvertibleError, ValueError) as exc:
        return str(exc)
    return None
