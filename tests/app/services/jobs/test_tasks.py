"""The diagnosis job is given the session's typed model (no model document on its way)."""

from __future__ import annotations

import pickle

import numpy as np

from app.services.explore.config import Config
from app.services.jobs import tasks
from app.services.session.sessions import Session
from core.base import Model
from core.presets import get_preset, list_presets
from core.recordings import Recording


def _recording() -> Recording:
    t = np.arange(400, dtype=np.float64) * 1e-3
    u = 3 * np.sin(2 * np.pi * 5 * t)
    return Recording(t, u, np.tanh(u) + 0.2 * u)


def test_the_diagnosis_job_is_sent_the_sessions_model() -> None:
    s = Session("ABCDEFGHJK")
    s.set_recording(_recording())
    task = tasks.diagnose_task(s)
    model = task.args[1]
    assert isinstance(model, Model)
    assert model.to_dict() == s.config.model  # the config's model, not a document of it
    assert s.model.to_dict() == s.config.model


def test_the_diagnosis_job_is_sent_the_fitted_model() -> None:
    from app.services.analysis.fitting import fit_recording

    s = Session("ABCDEFGHJK")
    rec = _recording()
    s.set_recording(rec)
    out = fit_recording(rec, 4, "pi")
    s.set_fit(out)
    assert tasks.diagnose_task(s).args[1] is out.model


def test_every_presets_model_travels_to_a_worker_as_it_is() -> None:
    """A job's arguments are pickled to its worker process: a model of every preset comes
    back equal (the same document, the same output)."""
    u = np.linspace(-2.0, 2.0, 50)
    for p in list_presets():
        cfg = Config(model=get_preset(p.name).to_dict())
        s = Session("ABCDEFGHJK", cfg)
        m = s.model
        back = pickle.loads(pickle.dumps(m))
        assert back.to_dict() == m.to_dict(), p.name
        dt = 1e-3 if m.is_dynamic else None
        np.testing.assert_array_equal(back(u, dt=dt), m(u, dt=dt), err_msg=p.name)
