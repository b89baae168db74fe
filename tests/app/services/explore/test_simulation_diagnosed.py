"""The explorer's Inverse and Closed-loop views compensate the diagnosed (extended) model."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from app.services.explore.config import Config
from app.services.explore.simulation import closed_loop, compute, diagnosed_model
from core.base import Chain
from core.pi import PIModel
from core.stages import Creep


def test_inverse_and_closed_loop_views_use_the_diagnosed_model() -> None:
    cfg = Config()
    base = compute(cfg)
    pi = base.model if isinstance(base.model, PIModel) else None
    assert pi is not None
    ext = Chain.of(pi, Creep([0.01, 0.1], [0.05, 0.05]))
    session = SimpleNamespace(diagnosed=ext)  # a session's typed state holds the Model
    assert diagnosed_model(session) is ext
    assert diagnosed_model(SimpleNamespace(diagnosed=None)) is None
    res = compute(cfg, diagnosed=diagnosed_model(session))
    # the compensated output follows the desired one through the *extended* model ...
    np.testing.assert_allclose(res.y_comp, res.u, rtol=0, atol=1e-9)
    # ... with a drive that differs from the PI-only compensator's (the creep is inverted)
    assert np.max(np.abs(res.v - base.v)) > 1e-3
    cl, msg = closed_loop(res, 0.0)
    assert cl is not None and "diagnosed model" in msg
    assert "inverse feedforward" in cl.runs
    run = cl.runs["inverse feedforward"]
    assert np.all(np.isfinite(run.y))
    # the feedforward is the extended inverse: compare with the PI-only loop's
    pi_run = closed_loop(base, 0.0)[0].runs["inverse feedforward"]
    n = run.v.size
    assert n < pi_run.v.size  # the diagnosed loop runs a shorter window
    assert np.max(np.abs(run.v - pi_run.v[:n])) > 1e-3


def test_explorer_c_download_of_a_diagnosed_chain_bakes_in_the_sample_time() -> None:
    from app.services.session.exports import export_bytes
    from core.stages import Delay, Resonance

    ext = Chain.of(PIModel(1.0, [0.5], [0.2]), Creep([0.01, 0.1], [0.05, 0.05]),
                   Resonance(300.0, 0.05), Delay(3e-4))
    name, payload = export_bytes(ext, "c", dt=1e-4)
    text = payload.decode()
    assert name.endswith(".c") and "hyst_inv_step" in text and "hyst_fwd_step" in text
    assert "#define HYST_INV_PREVIEW 3" in text
