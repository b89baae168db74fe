"""The inverse a figure request runs is priced from the inverse's own declared cost
(issue 18): the compensation of the Inverse view (of the diagnosed chain when the session
holds one, else of the config's model) and the diagnosed chain's closed loop, so that heavy
inverse work goes to a killable worker (:data:`app.services.session.actions.KILLABLE_WORK`).

Before, only the config's forward model was priced: a small PI config whose diagnosed chain
held a 200-coefficient asymmetry (its inverse about 2.5e9 units on 20,000 samples) or whose
Closed-loop view stepped the chain 7,000 times in Python ran in the server's thread, where
no hang-up could stop it. The priced costs bounding measured time and memory is checked
for these inverses in ``test_cost_memory.py`` and ``benchmarks/bench_cost.py``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from app.services.explore.config import Config, SignalSpec
from app.services.session import actions
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings
from core.base import Chain
from core.exceptions import ParameterError
from core.pi import PIModel
from core.stages import Asymmetry, Creep

SETTINGS = Settings()
SMALL_PI = {"type": "pi", "p0": 1.0, "thresholds": [0.5, 1.0], "weights": [0.3, 0.2]}
SIGNAL = SignalSpec(samples=20_000)


@pytest.fixture
def session() -> object:
    s = SessionRegistry().create()
    actions.change_config(s, lambda c: replace(c.with_model(SMALL_PI), signal=SIGNAL), SETTINGS)
    return s


def test_a_diagnosed_chains_heavy_inverse_goes_to_a_worker(
        session: object, monkeypatch: pytest.MonkeyPatch) -> None:
    heavy = Chain.of(PIModel(1.0, [0.5, 1.0], [0.3, 0.2]),
                     Asymmetry(np.full(100, 1e-5), 0.0, 4.0))  # its inverse ~1.4e9 units
    monkeypatch.setattr(actions, "diagnosed_model", lambda s: heavy)
    run = actions.session_figures_run  # the config alone is cheap: its views stay here
    assert not run(session, ["loop"], SETTINGS).killable
    assert run(session, ["inverse"], SETTINGS).killable
    # four times the coefficients: over the limit of one request, refused before any work
    heavier = Chain.of(PIModel(1.0, [0.5, 1.0], [0.3, 0.2]),
                       Asymmetry(np.full(400, 1e-5), 0.0, 4.0))
    monkeypatch.setattr(actions, "diagnosed_model", lambda s: heavier)
    with pytest.raises(ParameterError, match="Inverse view of the diagnosed model on 20,000 "
                                             "samples is priced at "
                                             r"\d,\d{3},\d{3},\d{3} units of work, more "
                                             "than the limit of 5,000,000,000"):
        run(session, ["inverse"], SETTINGS)
    monkeypatch.setattr(actions, "diagnosed_model", lambda s: heavy)
    light = Chain.of(PIModel(1.0, [0.5, 1.0], [0.3, 0.2]), Creep([0.01, 0.1], [0.02, 0.01]))
    monkeypatch.setattr(actions, "diagnosed_model", lambda s: light)
    assert not run(session, ["inverse"], SETTINGS).killable  # a light inverse stays here
    # its closed loop steps the chain and its inverse one sample per call, 7,000 times
    assert run(session, ["closed-loop"], SETTINGS).killable


def test_the_config_models_inverse_is_priced_too() -> None:
    asym = {"type": "asymmetry", "coefficients": [1e-4] * 30, "center": 0.0, "scale": 4.0}
    cfg = Config(model=asym, signal=SIGNAL)
    assert not actions.simulate_run(cfg, ["time"], SETTINGS).killable
    assert actions.simulate_run(cfg, ["inverse"], SETTINGS).killable
