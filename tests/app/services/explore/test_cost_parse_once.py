"""A session's model is built from its document once per config, not on every render."""

from __future__ import annotations

import core.base
from app.services.explore import simulation as sim
from app.services.session import actions
from app.services.session.sessions import Session
from app.services.settings import Settings


def _count(monkeypatch) -> list[int]:
    calls = [0]
    real = core.base.model_from_dict

    def counted(d):
        calls[0] += 1
        return real(d)

    monkeypatch.setattr(core.base, "model_from_dict", counted)  # cost.checked_model's
    monkeypatch.setattr(sim, "model_from_dict", counted)  # compute's, without a model
    return calls


def test_a_config_change_parses_once_and_renders_parse_nothing(monkeypatch) -> None:
    calls = _count(monkeypatch)
    s, settings = Session("abc"), Settings()
    actions.change_config(s, lambda c: c.with_model({**c.model, "p0": 0.5}), settings)
    assert calls[0] == 1
    for views in (["loop"], ["time", "inverse"], ["digitized"]):
        res = actions.session_result(s, views, settings)
        assert actions.session_model(s, settings) is res.model
    assert calls[0] == 1
    assert res.model.p0 == 0.5


def test_a_pushed_model_is_parsed_at_its_first_render_only(monkeypatch) -> None:
    calls = _count(monkeypatch)
    s, settings = Session("abc"), Settings()
    actions.load_preset(s, "paper001-example4", with_input=True)
    assert calls[0] == 0
    actions.session_result(s, ["loop"], settings)
    actions.session_result(s, ["operators"], settings)
    assert calls[0] == 1
    v = s.version
    s.update(lambda c: c.with_model({**c.model}))  # a new config: its model is built anew
    actions.session_result(s, ["loop"], settings)
    assert calls[0] == 2 and s.version == v + 1
