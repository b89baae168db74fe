"""Recordings in periodic steady state start the fit's model from the memory their own cycle
leaves (:mod:`core.fitting.steadystate`), and the saved model replays them as the report says.

The plant is written here with numpy (play operators of thresholds ``R`` and weights ``W``), not
with the project's operators."""

from __future__ import annotations

import numpy as np

from core.fitting import fit_recordings
from core.fitting.steadystate import SteadyStart, steady_state_history, warm_up
from core.recordings import Recording

R = np.array([0.15, 0.375, 0.6, 0.825])  # (on the fit's uniform grid of 12 plays)
W = np.array([0.8, 0.6, 0.4, 0.3])
N = 240


def _plant(u: np.ndarray, z0: np.ndarray) -> np.ndarray:
    """Output ``0.5 u + W . plays(u)`` of play operators started at ``z0``."""
    z = z0.astype(float).copy()
    y = np.empty(u.size)
    for k, x in enumerate(u):
        z = np.clip(z, x - R, x + R)
        y[k] = 0.5 * x + W @ z
    return y


def _loop(amp: float, name: str) -> Recording:
    """One closed loop of the plant, starting at its peak input after a cycle has set the
    memory (periodic steady state), no time axis, 0.05 % noise."""
    u = amp * np.cos(2 * np.pi * np.arange(N) / N)
    y = _plant(np.concatenate((u, u)), np.zeros(R.size))[N:]
    y = y + 5e-4 * np.ptp(y) * np.random.default_rng(int(10 * amp)).standard_normal(N)
    return Recording(np.arange(N, dtype=float), u, y, name=name, has_time=False)


def _held_out_pct(recs: list[Recording], model, histories: list) -> float:
    """RMSE on the last fifth of every loop, % of its output range, each loop replayed as the
    report says: the play operators relaxed at input 0, the loop's extremes, then the loop
    (plays are rate-independent: the extremes give the warm-up ramp's state)."""
    err, held = [], []
    for r, h in zip(recs, histories, strict=True):
        d = model.to_dict()
        d["stages"][0]["state0"] = [0.0] * len(d["stages"][0]["thresholds"])
        out = type(model).from_dict(d)(np.concatenate((h, r.u)))[len(h):]
        cut = N - int(round(0.2 * N))
        err.append((r.y - out)[cut:])
        held.append(r.y[cut:])
    e = np.concatenate(err)
    return 100.0 * float(np.sqrt(np.mean(e * e))) / float(np.ptp(np.concatenate(held)))


def test_closed_loops_starting_at_their_peak_are_fitted_from_their_cycles_memory() -> None:
    recs = [_loop(1.0, "big"), _loop(0.6, "small")]
    # the cycle's two extremes (in the order the input visits them; a loop that starts at
    # its peak reaches the same memory whichever comes first)
    for r in recs:
        assert sorted(steady_state_history(r)) == [r.u[1:].min(), r.u[1:].max()]
    out = fit_recordings(recs, "pi", n_operators=12)
    mem = out.report.extra["initial_memory"]
    assert "periodic steady state" in mem["summary"] and "Every row" in mem["summary"]
    assert mem["excluded_train_rows"] == 0
    hist = mem["steady_state"]
    # relaxed at each loop's first sample instead: a few % of range on the held-out rows
    assert out.report.test.rmse_pct < 0.5
    # the saved model replays every loop as the report scored it
    pct = _held_out_pct(recs, out.parameter_set.model, hist)
    assert np.isclose(pct, out.report.test.rmse_pct, rtol=1e-6)
    assert out.parameter_set.to_dict()["provenance"]["fit"]["report"]["extra"]["initial_memory"][
        "steady_state"] == hist


def test_a_recording_from_rest_keeps_the_relaxed_start() -> None:
    t = np.arange(2000) * 1e-3
    u = np.sin(2 * np.pi * 2 * t) * np.minimum(1.0, t / 0.6)
    rec = Recording(t, u, _plant(u, np.zeros(R.size)))
    start = SteadyStart.of([rec])
    assert start.history == ((),) and start.warm == ()
    assert start.padded([rec])[0] is rec
    out = fit_recordings(rec, "pi", n_operators=12)
    assert "steady_state" not in out.report.extra["initial_memory"]
    assert "periodic steady state" not in out.report.summary()


def test_warm_up_ramps_through_the_extremes_to_the_first_sample() -> None:
    w = warm_up((-1.0, 2.0), 0.5, n=4)
    assert np.allclose(w, [0.0, -0.25, -0.5, -0.75, -1.0, -0.25, 0.5, 1.25, 2.0, 1.625, 1.25,
                           0.875])
    assert warm_up((), 0.5).size == 0


def test_a_unipolar_cycle_warms_up_inside_its_range_and_keeps_its_thresholds() -> None:
    """A steady cycle that does not reach input 0 (a drive at 2-4, like a unipolar piezo
    amplifier): the warm-up starts at the cycle's input nearest 0, never further than the
    cycle travels, so the plays are placed on the cycle's own travels (all narrower than its
    half-range of 1) and the fit is as good as that of the same rows started relaxed."""
    k = np.arange(4 * N)
    u = 3.0 + np.cos(2 * np.pi * k / N)
    y = _plant(np.concatenate((u[:N], u)), np.zeros(R.size))[N:]
    y = y + 5e-4 * np.ptp(y) * np.random.default_rng(3).standard_normal(y.size)
    rec = Recording(np.arange(y.size, dtype=float), u, y, "unipolar", has_time=False)
    assert sorted(steady_state_history(rec)) == [2.0, 4.0]
    w = SteadyStart.of([rec]).warm[0]
    assert w[0] == 2.0 and w.min() >= 2.0 and w.max() <= 4.0
    out = fit_recordings(rec, "pi", n_operators=12)
    r = np.asarray(out.parameter_set.model.to_dict()["stages"][0]["thresholds"])
    assert r.max() < 1.0  # (a ramp from 0 placed them up to 1.8: half never moved)
    # the same recording with its first rows perturbed (not in steady state: relaxed start)
    rough = Recording(rec.t, np.concatenate((np.full(30, 3.0), u[30:])), y, "rough",
                      has_time=False)
    ref = fit_recordings(rough, "pi", n_operators=12)
    assert out.report.test.rmse < 2.0 * ref.report.test.rmse
    # the stored wipe-out time counts the recording's own rows, not the warm-up's
    tw = out.report.extra["initial_memory"].get("wipeout_index")
    assert tw is None or max(tw) <= rec.n_samples


def test_warm_up_of_a_cycle_around_zero_starts_at_zero() -> None:
    assert warm_up((-1.0, 2.0), 0.5, n=2)[0] == 0.0
    assert warm_up((5.0, 7.0), 6.0, n=2)[0] == 5.0 and warm_up((-7.0, -5.0), -6.0, n=2)[0] == -5.0
