"""Input checking and train / held-out labelling shared by the regressors."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .._typing import ArrayLike, Float1D
from ..exceptions import ParameterError, UnsupportedOptionError
from ..validation import as_input_signal
from .gram import Segment

__all__ = [
    "Prepared",
    "as_recordings",
    "exclude_before_wipeout",
    "masked_range",
    "prepare",
    "unpack_recordings",
]


def _is_multi(x: Any) -> bool:
    """A list/tuple whose first element is itself one-dimensional: several recordings."""
    if isinstance(x, (list, tuple)) and len(x) > 0:
        first = x[0]
        return np.ndim(first) == 1 and not isinstance(first, (str, bytes))
    return False


def as_recordings(u: Any, name: str = "u") -> tuple[list[Float1D], bool]:
    """Return ``(list of validated signals, was_multi)``; a single array becomes a 1-list."""
    if _is_multi(u):
        return [as_input_signal(x, f"{name}[{k}]") for k, x in enumerate(u)], True
    return [as_input_signal(u, name)], False


def _is_recording(x: Any) -> bool:
    return all(hasattr(x, a) for a in ("t", "u", "y")) and not isinstance(x, np.ndarray)


def unpack_recordings(u: Any, y: Any) -> tuple[Any, Any]:
    """Allow ``fit(recording)`` / ``fit([rec1, rec2])`` (objects with ``t, u, y``).

    Returns ``(u, y)`` unchanged when ``y`` is given.

    Raises
    ------
    ParameterError
        If ``y`` is missing and ``u`` is not a recording or a list of recordings.
    """
    if y is not None:
        return u, y
    if _is_recording(u):
        return u.u, u.y
    if isinstance(u, (list, tuple)) and u and all(_is_recording(r) for r in u):
        return [r.u for r in u], [r.y for r in u]
    raise ParameterError(
        "y is missing: pass fit(u, y), or fit(recording) / fit([recordings]) with objects "
        "that have t, u and y (core.recordings.Recording)"
    )


def _mask(m: Any, n: int, what: str, k: int) -> np.ndarray | None:
    if m is None:
        return None
    a = np.asarray(m)
    if a.dtype != bool:
        raise ParameterError(f"{what} for recording {k} must be a boolean mask of length {n}")
    if a.shape != (n,):
        raise ParameterError(
            f"{what} for recording {k} has shape {a.shape}, expected ({n},) like u"
        )
    return a


@dataclass(frozen=True, eq=False)
class Prepared:
    """Validated recordings with per-sample labels.

    Attributes
    ----------
    us, ys : list of ndarray
        Inputs and outputs per recording.
    train_masks, test_masks : list of ndarray of bool
    multi : bool
        Whether ``fit`` was given several recordings.
    n_train, n_test : int
    """

    us: list[Float1D]
    ys: list[Float1D]
    train_masks: list[np.ndarray]
    test_masks: list[np.ndarray]
    multi: bool
    n_train: int
    n_test: int

    def segments(self, n_blocks: int = 1, z0s: Sequence[Float1D | None] | None = None):
        """Segments labelled ``0..n_blocks-1`` (contiguous training blocks) and ``n_blocks``
        (held-out); other samples ``-1``."""
        total = self.n_train
        done = 0
        segs = []
        for k, (u, y, tr, te) in enumerate(
            zip(self.us, self.ys, self.train_masks, self.test_masks, strict=True)
        ):
            lab = np.full(u.size, -1, dtype=np.int8)
            if n_blocks == 1:
                lab[tr] = 0
            else:
                cum = done + np.cumsum(tr) - 1
                blk = np.minimum((cum * n_blocks) // max(total, 1), n_blocks - 1)
                lab[tr] = blk[tr].astype(np.int8)
            done += int(tr.sum())
            lab[te] = n_blocks
            z0 = None if z0s is None else z0s[k]
            segs.append(Segment(u=u, y=y, labels=lab, z0=z0))
        return segs


def prepare(
    u: Any,
    y: Any,
    train: Any = None,
    test: Any = None,
    *,
    validation: float | None = 0.2,
    min_train: int = 20,
) -> Prepared:
    """Validate ``(u, y)`` (one or several recordings) and build the train / held-out masks.

    Rules: with neither mask, the last ``validation`` fraction of every recording is held out
    and the rest is training; with only ``train``, nothing is held out; with only ``test``,
    training is the complement; with both, they must not overlap. Samples in neither part
    still drive the operator states (they are simulated, not scored).

    Raises
    ------
    ParameterError
        Mismatched lengths or numbers of recordings, NaN/inf samples, too few training
        samples, a constant input or a constant output (each message names the problem).
    """
    u, y = unpack_recordings(u, y)
    us, multi = as_recordings(u, "u")
    ys, multi_y = as_recordings(y, "y")
    if multi != multi_y or len(us) != len(ys):
        raise ParameterError(
            f"u holds {len(us)} recording(s) but y holds {len(ys)}; pass matching lists"
        )
    for k, (a, b) in enumerate(zip(us, ys, strict=True)):
        if a.size != b.size:
            where = f" in recording {k}" if multi else ""
            raise ParameterError(
                f"u has {a.size} samples but y has {b.size}{where}; they must have equal length"
            )
    trs = train if (multi and train is not None) else [train] * len(us)
    tes = test if (multi and test is not None) else [test] * len(us)
    if len(trs) != len(us) or len(tes) != len(us):
        raise ParameterError("train/test must give one mask per recording")
    if validation is not None and not (0.0 <= float(validation) < 1.0):
        raise ParameterError(f"validation = {validation!r} must be a fraction in [0, 1)")
    train_masks, test_masks = [], []
    for k, (a, t0, t1) in enumerate(zip(us, trs, tes, strict=True)):
        tr = _mask(t0, a.size, "train", k)
        te = _mask(t1, a.size, "test", k)
        if tr is None and te is None:
            cut = a.size - int(round((validation or 0.0) * a.size))
            tr = np.zeros(a.size, dtype=bool)
            tr[:cut] = True
            te = ~tr
        elif te is None:
            te = np.zeros(a.size, dtype=bool)
        elif tr is None:
            tr = ~te
        assert tr is not None and te is not None  # every branch above fills both
        if (tr & te).any():
            raise ParameterError(f"train and test masks overlap in recording {k}")
        train_masks.append(tr)
        test_masks.append(te)
    n_train = int(sum(int(m.sum()) for m in train_masks))
    n_test = int(sum(int(m.sum()) for m in test_masks))
    if n_train < min_train:
        raise ParameterError(
            f"too few training samples: {n_train} (need at least {min_train} for this model)"
        )
    if masked_range(us) == 0.0:
        raise ParameterError(
            f"u is constant (every sample = {us[0][0]:g}); hysteresis needs input travel"
        )
    if masked_range(ys, train_masks) == 0.0:
        raise ParameterError(
            "y is constant on the training samples; there is nothing to fit"
        )
    return Prepared(us, ys, train_masks, test_masks, multi, n_train, n_test)


#: Fewest training rows (fraction) that must remain after leaving out the pre-wipe-out rows.
MIN_KEPT_AFTER_WIPEOUT = 1.0 / 3.0


#: The ``initial_memory`` rules of the estimators that can leave the pre-wipe-out rows out.
INITIAL_MEMORY_RULES: tuple[str, ...] = ("exclude", "keep")


def check_initial_memory(estimator: Any) -> None:
    """Check ``estimator.initial_memory`` against its class's ``initial_memory_rules``.

    Every estimator takes ``initial_memory``; those that always fit from the relaxed state
    declare ``initial_memory_rules = ("keep",)``.

    Raises
    ------
    ParameterError
        Not one of ``"exclude"``, ``"keep"``.
    UnsupportedOptionError
        A rule the estimator cannot apply (the message names the ones it can).
    """
    rule = estimator.initial_memory
    allowed = type(estimator).initial_memory_rules
    if rule not in INITIAL_MEMORY_RULES:
        raise ParameterError(f"initial_memory must be 'exclude' or 'keep', got {rule!r}")
    if rule not in allowed:
        raise UnsupportedOptionError(
            f"{type(estimator).__name__} cannot use initial_memory={rule!r}: it fits every "
            f"training row from the relaxed state; use {' or '.join(map(repr, allowed))}")


def exclude_before_wipeout(prep: Prepared, rule: str) -> tuple[Prepared, dict[str, Any]]:
    """Leave the training rows before each recording's wipe-out time out of the fit.

    Parameters
    ----------
    prep : Prepared
    rule : {"exclude", "keep"}
        ``"exclude"``: drop them when at least :data:`MIN_KEPT_AFTER_WIPEOUT` of the training
        rows remain; ``"keep"``: leave the masks unchanged.

    Returns
    -------
    prepared : Prepared
        With the new training masks (and counts).
    note : dict
        ``{"rule", "excluded_train_rows", "wipeout_index", "summary"}``: what was done, for
        the fit report.
    """
    from .thresholds import wipeout_index

    if rule not in ("exclude", "keep"):
        raise ParameterError(f"initial_memory must be 'exclude' or 'keep', got {rule!r}")
    tws = [wipeout_index(u) for u in prep.us]
    pre = [m & (np.arange(m.size) < tw) for m, tw in zip(prep.train_masks, tws, strict=True)]
    n_pre = int(sum(int(p.sum()) for p in pre))
    kept = prep.n_train - n_pre
    note: dict[str, Any] = {"rule": rule, "excluded_train_rows": 0, "wipeout_index": tws}
    if rule == "keep" or n_pre == 0:
        note["summary"] = ("initial memory: every training row fitted from the relaxed state"
                           if n_pre else "initial memory: no training row before the "
                           "wipe-out time")
        return prep, note
    if kept < MIN_KEPT_AFTER_WIPEOUT * prep.n_train:
        note["summary"] = (f"initial memory: kept the {n_pre} training rows before the "
                           f"wipe-out time (leaving them out would keep only {kept} of "
                           f"{prep.n_train}); they assume the relaxed state")
        return prep, note
    masks = [m & ~p for m, p in zip(prep.train_masks, pre, strict=True)]
    note["excluded_train_rows"] = n_pre
    note["summary"] = (f"initial memory unknown: the {n_pre} training rows before the "
                       "wipe-out time (until the input first reached both ends of its range) "
                       "were left out of the weight fit; they only drive the operator states")
    return replace(prep, train_masks=masks, n_train=kept), note


def masked_range(xs: Sequence[Float1D], masks: Sequence[np.ndarray] | None = None) -> float:
    """``max - min`` over several signals (optionally only where ``masks`` is true)."""
    lo, hi = np.inf, -np.inf
    for k, x in enumerate(xs):
        v = x if masks is None else x[masks[k]]
        if v.size:
            lo = min(lo, float(v.min()))
            hi = max(hi, float(v.max()))
    return hi - lo if hi >= lo else 0.0


def check_predict_input(u: ArrayLike) -> tuple[list[Float1D], bool]:
    """Validate ``predict`` input (one or several recordings)."""
    us, multi = as_recordings(u, "u")
    return us, multi
