"""The explorer computation (``app.services.explore.simulation``):
default config, perturbation, signals.

Also: operator contributions in chunks, and no web import below the routers."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from app.services.explore import config as S
from app.services.explore import simulation as C
from core.exceptions import ParameterError
from core.pi import PIModel
from core.signals import SIGNALS


def test_service_modules_have_no_web_imports() -> None:
    import subprocess

    code = ("import sys, app.services.session.sessions, app.services.explore.simulation, "
            "app.services.analysis.recordings, app.services.analysis.fitting, "
            "app.services.analysis.diagnosis, "
            "app.services.session.exports; "
            "print([m for m in ('viser', 'fastapi', 'plotly') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_default_config_is_paper001_example1() -> None:
    res = C.compute(S.Config())
    m = PIModel.from_dict(S.EXAMPLE1)
    np.testing.assert_allclose(res.u, 4 * np.sin(2 * np.pi * res.t), atol=1e-12)
    np.testing.assert_allclose(res.y, m(res.u))
    k = res.contrib_idx
    np.testing.assert_allclose(res.contributions.sum(axis=1) + m.p0 * res.u[k], res.y[k],
                               atol=1e-12)
    np.testing.assert_allclose(res.y_comp, res.u, atol=1e-9)  # P(P^-1(u)) = u


def test_perturb_changes_the_plant_only_when_asked() -> None:
    m = PIModel.from_dict(S.EXAMPLE1)
    assert C.perturb(m, 0.0) is m
    p = C.perturb(m, 0.2)
    np.testing.assert_allclose(p.thresholds, 1.2 * m.thresholds)
    np.testing.assert_allclose(p.weights, 0.8 * m.weights)


def test_signal_validation_messages() -> None:
    with pytest.raises(ParameterError, match="samples"):
        S.SignalSpec(samples=10**7).validate(1000)
    with pytest.raises(ParameterError, match="kind"):
        S.SignalSpec(kind="nope").validate(1000)
    with pytest.raises(ParameterError, match="operators"):
        C.build_model({"type": "pi", "p0": 1, "thresholds": [1, 2, 3], "weights": [1, 1, 1]}, 2)


def test_every_signal_kind_builds() -> None:
    for kind in SIGNALS:
        t, u = C.make_signal(S.SignalSpec(kind=kind, samples=500))
        assert t.shape == u.shape and np.isfinite(u).all()


def test_chunked_contributions_match_the_full_matrix() -> None:
    m = PIModel(0.5, [0.3, 0.8, 1.9], [0.4, 0.3, 0.2], [0.1, -0.2, 0.3])
    t = np.linspace(0, 5, 47_001)
    u = 3 * np.sin(2 * np.pi * 3 * t) * np.exp(-0.3 * t)
    idx, c = C.operator_contributions(m, u)
    np.testing.assert_allclose(c, (m.operator_outputs(u) * m.weights)[idx], atol=1e-12)
