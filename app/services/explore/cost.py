"""The cost model: every request's work is bounded and checked before any work starts.

Two steps, both cheap and non-recursive where the input is hostile:

1. :func:`json_depth` / :func:`check_document` look at the raw JSON (bytes or the parsed
   document) *before* a model is built: nesting depth, how many numbers, LTI order. A chain
   nested 300 deep or an LTI of order 1,500 is refused here, before ``model_from_dict``
   recurses or realises anything.
2. :func:`check_model` looks at the built model and the run it is asked for (number of
   samples, sample spacing ``dt``): play operators over every type that has them (``pi``,
   ``rate``, ``initial-memory``, ``digitized``, the GPI family), creep terms, LTI order,
   delay in samples (delays and advances, priced without overflow), time constants
   against ``dt``, the coarse work ``samples x (operators + creep terms + LTI order +
   stages)``, and the priced work and memory: the sum over the model tree of each
   stage's own :meth:`core.base.Model.cost` (every registered type declares it from its
   fields: terms x samples, coefficients x samples x bisection steps, delay buffers, ...).

Every refusal is a :class:`~core.exceptions.ParameterError` (a 422 in the API) naming the
quantity, its value, the limit and what to change. The limits are :class:`Limits`, shown by
``GET /api/capabilities`` and in docs/pages/serve.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from core.base import Model, RunCost
from core.exceptions import ParameterError
from core.lti import LinearSystem
from core.stages import Advance, Creep, CreepInverse, Delay

__all__ = ["CALL_WORK", "CheckedModel", "Cost", "Limits", "check_config", "check_document",
           "check_model", "checked_config", "checked_model", "json_depth", "priced_run",
           "priced_steps"]


@dataclass(frozen=True)
class Limits:
    """Upper bounds of one request's work.

    Parameters
    ----------
    max_operators : int
        Play operators (or digits) summed over every stage of a model.
    max_samples : int
        Samples of a simulated signal or an uploaded recording.
    max_json_depth : int
        Nesting of a JSON body (objects and arrays).
    max_model_depth : int
        Nesting of models inside models (chains of chains, wrappers).
    max_numbers : int
        Numbers in one model document (all arrays together).
    max_creep_terms : int
        Lags of a creep stage, summed over the model.
    max_lti_order : int
        Order (denominator degree) of an ``lti`` stage.
    min_tau_per_dt, max_tau_per_dt : float
        Time constants (lag ``tau_s``, creep ``taus_s``, ``1 / (2 pi freq_hz)`` of a
        resonance) relative to the sample spacing ``dt``: outside this range the stage is
        either a no-op or numerically singular.
    max_work : int
        ``samples x (operators + creep terms + LTI order + stages)`` of one simulation.
    max_total_work : float
        Priced work of one simulation, in element operations (about a nanosecond each):
        the sum of :meth:`core.base.Model.cost` over the model tree.
    max_memory_bytes : float
        Priced memory of one simulation (bytes), summed the same way; also of one figure
        request (the model's run and the views' extra runs together).
    max_figures_work : float
        Priced work of one figure request: the model's run and what its views run beyond
        it (the inverse of the Inverse view, the diagnosed chain's closed loop, which steps
        the chain one sample per call 7,000 times: about 2.1e9 on its own).
    """

    max_operators: int = 100
    max_samples: int = 200_000
    max_json_depth: int = 40
    max_model_depth: int = 10
    max_numbers: int = 20_000
    max_creep_terms: int = 50
    max_lti_order: int = 20
    min_tau_per_dt: float = 1e-9
    max_tau_per_dt: float = 1e6
    max_work: int = 25_000_000
    max_total_work: float = 2e9
    max_memory_bytes: float = 1.5e9
    max_figures_work: float = 5e9

    def to_dict(self) -> dict[str, float]:
        """JSON-ready form, each limit by name (``GET /api/capabilities``)."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Cost:
    """What one simulation of a model costs (see :func:`check_model`).

    ``work`` is the coarse ``samples x (operators + creep terms + lti order + stages)``;
    ``total_work`` (element operations) and ``memory_bytes`` are the sums of every stage's
    :meth:`core.base.Model.cost`.
    """

    operators: int
    creep_terms: int
    lti_order: int
    delay_samples: int
    stages: int
    work: int
    total_work: float = 0.0
    memory_bytes: float = 0.0


@dataclass(frozen=True, eq=False)
class CheckedModel:
    """A config's model, built once from its document and checked against ``limits``.

    A session keeps the one of its current config and recording
    (:attr:`app.services.storage.store.SessionState.checked`), so a render neither parses nor
    checks the model again.
    """

    model: Model
    cost: Cost
    limits: Limits
    #: the run it was priced for: samples and their spacing, s
    samples: int = 0
    dt: float = 1.0
    #: priced work and memory of the views' extra runs, by views (filled by its users: the
    #: inverse is built once per config, not per request)
    views_work: dict[frozenset[str], RunCost] = dataclasses.field(default_factory=dict)


# ----------------------------------------------------------------------------- raw JSON
def json_depth(body: bytes) -> int:
    """Largest nesting depth of the JSON text ``body`` (vectorised, never recursive).

    Brackets inside strings do not count. Invalid JSON still gets a depth (the parser
    rejects it afterwards); the point is to refuse deep bodies before a recursive parser
    or model builder sees them.
    """
    if not body:
        return 0
    b = body.replace(b"\\\\", b"__").replace(b'\\"', b"__")
    a = np.frombuffer(b, dtype=np.uint8)
    in_str = np.cumsum(a == ord('"')) % 2 == 1
    step = np.zeros(a.size, dtype=np.int32)
    step[(a == ord("{")) | (a == ord("["))] = 1
    step[(a == ord("}")) | (a == ord("]"))] = -1
    step[in_str] = 0
    return int(np.cumsum(step).max(initial=0))


def check_document(doc: Any, limits: Limits, where: str = "model") -> None:
    """Refuse a model document that is too deep, too big or of too high an LTI order, or
    whose ``type`` fields are not names (text).

    Walks ``doc`` with an explicit stack (no recursion), so any parsed JSON is safe.

    Parameters
    ----------
    doc : object
        The parsed model document.
    limits : Limits
        The limits.
    where : str
        The document's path, for the messages (``model``, ``body.model``).

    Raises
    ------
    ParameterError
        Naming the limit that was exceeded, or the path of a ``type`` that is not text.
    """
    numbers = 0
    # (node, json depth, model depth, path)
    stack: list[tuple[Any, int, int, str]] = [(doc, 1, 0, where)]
    while stack:
        node, depth, mdepth, path = stack.pop()
        if depth > limits.max_json_depth:
            raise ParameterError(
                f"the model document is nested more than {limits.max_json_depth} levels "
                "deep; flatten the chain (a chain's stages may be listed in one chain)")
        if isinstance(node, dict):
            if "type" in node:
                if not isinstance(node["type"], str):
                    raise ParameterError(
                        f"{path}.type must be the name of a model type, as text (such as "
                        f"\"pi\"), not {_kind(node['type'])}; see GET /api/capabilities for "
                        "the names")
                mdepth += 1
                if mdepth > limits.max_model_depth:
                    raise ParameterError(
                        f"models are nested more than {limits.max_model_depth} deep (chains "
                        "inside chains); list the stages in one chain instead")
                if node.get("type") == "lti" and isinstance(node.get("den"), list):
                    order = len(node["den"]) - 1
                    if order > limits.max_lti_order:
                        raise ParameterError(
                            f"lti order {order} exceeds the limit of {limits.max_lti_order}; "
                            "use a lower-order model (or a chain of low-order stages)")
            stack.extend((v, depth + 1, mdepth, f"{path}.{k}") for k, v in node.items())
        elif isinstance(node, list):
            numbers += sum(1 for v in node if isinstance(v, int | float))
            if numbers > limits.max_numbers:
                raise ParameterError(
                    f"the model document holds more than {limits.max_numbers:,} numbers; "
                    "the explorer's models are smaller (fewer operators or terms)")
            stack.extend((v, depth + 1, mdepth, f"{path}[{i}]") for i, v in enumerate(node)
                         if isinstance(v, dict | list))


def _kind(value: Any) -> str:
    """What a JSON value is, in words (``a list``, ``a number``)."""
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, int | float):
        return "a number"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "an object"
    return "null" if value is None else "a value of another kind"


# ----------------------------------------------------------------------------- built model
def _children(m: Model) -> list[Model]:
    """Sub-models of ``m``, found from its dataclass fields (each type declares them once)."""
    out: list[Model] = []
    assert dataclasses.is_dataclass(m)  # every registered Model is a dataclass
    for f in dataclasses.fields(m):
        v = getattr(m, f.name, None)
        if isinstance(v, Model):
            out.append(v)
        elif isinstance(v, tuple | list):
            out.extend(x for x in v if isinstance(x, Model))
    return out


def priced_run(model: Model, samples: int, dt: float) -> RunCost:
    """Sum of :meth:`core.base.Model.cost` over ``model``'s tree, with no limit checked
    (what :func:`check_model` prices; the benchmarks and tests compare it with measurements)."""
    total, todo = RunCost(0.0, 0.0), [model]
    while todo:
        m = todo.pop()
        total = total + m.cost(samples, dt)
        todo.extend(_children(m))
    return total


#: Priced work of one ``simulate`` call of one stage beyond its declared cost (validation,
#: state in and out, the Python around the kernels), element operations: 75-350 µs were
#: measured per stage call on the 2-core machine at load 14-18 (``bench_cost.py`` checks
#: the closed loops of the diagnosed chains, which call every stage once per sample).
CALL_WORK = 100_000.0


def priced_steps(model: Model, steps: int, dt: float) -> RunCost:
    """Price of running ``model`` one sample per call for ``steps`` samples (a closed loop's
    plant or feedforward): each stage's declared cost of one sample (:meth:`Model.cost`,
    fixed terms included) plus :data:`CALL_WORK`, per step; memory: one step's and the
    loop's sample arrays."""
    one, stages, todo = RunCost(0.0, 0.0), 0, [model]
    while todo:
        m = todo.pop()
        one = one + m.cost(1, dt)
        stages += 1
        todo.extend(_children(m))
    return RunCost(steps * (one.work + stages * CALL_WORK), one.memory + 8.0 * 8.0 * steps)


def _operators(m: Model) -> int:
    n = getattr(type(m), "n", None)
    if isinstance(n, property):
        return int(n.__get__(m))
    th = getattr(m, "thresholds", None)
    return int(np.size(th)) if th is not None else 0


def _delay_samples(kind: str, delay_s: float, dt: float, limits: Limits) -> int:
    """``delay_s`` in samples of ``dt``, compared without dividing (no overflow to inf).

    Raises
    ------
    ParameterError
        When the delay is longer than ``limits.max_samples`` samples.
    """
    if not delay_s <= limits.max_samples * dt:
        samples = delay_s / dt
        shown = f"{samples:.3g}" if math.isfinite(samples) else "more than 1e308"
        raise ParameterError(
            f"the {kind}'s delay_s = {delay_s:.3g} s is {shown} samples (dt = {dt:.3g} s); "
            f"the explorer allows at most {limits.max_samples:,}: shorten delay_s")
    return int(math.ceil(delay_s / dt))


def check_model(model: Model, samples: int, dt: float, limits: Limits) -> Cost:
    """Cost of simulating ``model`` on ``samples`` samples spaced ``dt`` seconds.

    Raises
    ------
    ParameterError
        When a limit of :class:`Limits` is exceeded (the message names it and the fix).
    """
    ops = creep = order = delay = stages = 0
    priced: list[tuple[Model, RunCost]] = []
    todo, depth_of = [model], {id(model): 1}
    while todo:
        m = todo.pop()
        stages += 1
        d = depth_of[id(m)]
        if d > limits.max_model_depth:
            raise ParameterError(f"models are nested more than {limits.max_model_depth} deep")
        kids = _children(m)
        for k in kids:
            depth_of[id(k)] = d + 1
        todo.extend(kids)
        ops += _operators(m)
        if isinstance(m, Creep | CreepInverse):
            terms = int(np.size(m.taus_s))
            creep += terms
            if creep > limits.max_creep_terms:
                raise ParameterError(
                    f"{m.type_name} has {terms:,} terms ({creep:,} in the model); the "
                    f"explorer allows at most {limits.max_creep_terms} (one lag per decade "
                    "of time is enough)")
        if isinstance(m, LinearSystem):
            order += int(np.size(m.den)) - 1
        if isinstance(m, Delay | Advance):  # an advance buffers its delay too
            d_s = float(m.delay_s)
            delay = max(delay, _delay_samples(m.type_name, d_s, dt, limits))
        for what, tau in m.time_constants():
            r = tau / dt
            if not limits.min_tau_per_dt <= r <= limits.max_tau_per_dt:
                raise ParameterError(
                    f"{what} = {tau:.3g} s is {r:.3g} sample spacings (dt = {dt:.3g} s); it "
                    f"must be between {limits.min_tau_per_dt:g} and {limits.max_tau_per_dt:g} "
                    "dt: change the time constant or the sample spacing")
        priced.append((m, m.cost(samples, dt)))
    if ops > limits.max_operators:
        raise ParameterError(
            f"model has {ops} operators; the explorer allows at most {limits.max_operators}")
    if order > limits.max_lti_order:
        raise ParameterError(
            f"lti order {order} exceeds the limit of {limits.max_lti_order}")
    if samples > limits.max_samples:
        raise ParameterError(
            f"{samples:,} samples exceed the limit of {limits.max_samples:,}")
    work = samples * (ops + creep + order + stages)
    if work > limits.max_work:
        raise ParameterError(
            f"this run costs {work:,} units (samples x (operators + creep terms + lti order + "
            f"stages) = {samples:,} x {ops + creep + order + stages}), more than "
            f"{limits.max_work:,}: use fewer samples or a smaller model")
    total = _priced_total(priced, samples, limits)
    return Cost(ops, creep, order, delay, stages, work, total.work, total.memory)


def _size_words(m: Model) -> str:
    """The sizes of ``m``'s array fields in words, e.g. ``"19,000 coefficients"``."""
    parts = [f"{np.size(getattr(m, f.name)):,} {f.name}" for f in m.fields
             if f.kind in ("numbers", "matrix") and getattr(m, f.name, None) is not None]
    return ", ".join(parts) or "no arrays"


def _priced_total(priced: list[tuple[Model, RunCost]], samples: int,
                  limits: Limits) -> RunCost:
    """Sum of the stages' priced costs, refused (naming the costliest stage) above the
    total-work or memory limit.

    Raises
    ------
    ParameterError
        When ``limits.max_total_work`` or ``limits.max_memory_bytes`` is exceeded.
    """
    total = RunCost(0.0, 0.0)
    for _, c in priced:
        total = total + c
    checks = (("work", "work", limits.max_total_work, "units", 1.0),
              ("memory", "memory", limits.max_memory_bytes, "MB", 1e6))
    for attr, what, limit, unit, scale in checks:
        value = getattr(total, attr)
        if not value <= limit:  # also refuses nan
            worst, wc = max(priced, key=lambda p: getattr(p[1], attr))
            raise ParameterError(
                f"this run is priced at {value / scale:,.0f} {unit} of {what} on {samples:,} "
                f"samples, more than the limit of {limit / scale:,.0f}; most of it is the "
                f"'{worst.type_name}' stage ({_size_words(worst)}: "
                f"{getattr(wc, attr) / scale:,.0f} {unit}): make that stage smaller "
                "(fewer coefficients, terms, operators or a shorter delay) or use fewer "
                "samples")
    return total


def checked_model(doc: Any, samples: int, dt: float, limits: Limits) -> tuple[Model, Cost]:
    """Build the model of ``doc`` only after :func:`check_document`, then :func:`check_model`.

    Raises
    ------
    ParameterError
        When a limit is exceeded or the document is not a valid model.
    """
    from core.base import model_from_dict

    check_document(doc, limits)
    if not isinstance(doc, dict):
        raise ParameterError("a model must be a JSON object with a 'type' field")
    model = model_from_dict(doc)
    return model, check_model(model, samples, dt, limits)


def check_config(cfg: Any, recording: Any, limits: Limits) -> Cost:
    """Cost of computing the figures of a :class:`~app.services.explore.config.Config` (see
    :func:`check_model`).

    The run is the recording's input when ``cfg.use_recording`` and there is one, else the
    config's signal (``samples`` samples over ``duration`` seconds).
    """
    return checked_config(cfg, recording, limits).cost


def checked_config(cfg: Any, recording: Any, limits: Limits) -> CheckedModel:
    """The model of ``cfg`` built once and its cost checked (:func:`check_config`).

    Raises
    ------
    ParameterError
        When a limit is exceeded or the document is not a valid model.
    """
    if cfg.use_recording and recording is not None:
        samples = int(recording.n_samples)
        dt = float(recording.dt) if getattr(recording, "dt", None) else 1.0
    else:
        samples = int(cfg.signal.samples)
        dt = float(cfg.signal.duration) / max(1, samples - 1)
    if not (math.isfinite(dt) and dt > 0):
        raise ParameterError(f"the sample spacing {dt!r} s must be a positive number")
    model, cost = checked_model(cfg.model, samples, dt, limits)
    return CheckedModel(model, cost, limits, samples, dt)
