"""The fit kinds come from the model registry: a model type that declares an estimator is one.

``hyst fit --model``, ``hyst batch fit --model``, ``GET /api/capabilities`` and the viser fit
menu all list :func:`core.models.fit_kinds`; a type registered with an ``estimator`` appears
in each of them (and is fitted by its estimator) without editing any list.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest
from fastapi.testclient import TestClient

import core.base
from app.cli import main
from app.server import create_app
from app.services.analysis.fitting import fit_recording
from app.services.settings import Settings
from core.base import register_model
from core.fitting import PIRegressor
from core.models import DEFAULT_FIT_KIND, estimator_class, fit_kinds, model_class
from core.paramset import load_parameter_set
from core.pi import PIModel
from core.recordings import Recording


class CountingPIRegressor(PIRegressor):
    """A PI estimator that counts its fits (to see that the declared estimator is used)."""

    fits: ClassVar[int] = 0

    def fit(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        type(self).fits += 1
        return super().fit(*args, **kwargs)


@dataclass(frozen=True, eq=False)
class ProbePI(PIModel):
    """A PI model type registered by the test only."""

    type_name: ClassVar[str] = "probe-pi"
    estimator: ClassVar[str | None] = f"{__name__}:CountingPIRegressor"


@pytest.fixture
def probe_registered(monkeypatch):
    """Register :class:`ProbePI` in a copy of the registry (restored after the test)."""
    monkeypatch.setattr(core.base, "_REGISTRY", dict(core.base._REGISTRY))
    register_model(ProbePI)
    CountingPIRegressor.fits = 0
    return ProbePI


def test_the_fit_kinds_are_the_types_that_declare_an_estimator() -> None:
    kinds = fit_kinds()
    assert kinds[0] == DEFAULT_FIT_KIND == "pi"
    assert set(kinds) == {"pi", "gpi-deadzone", "mpi", "gpi-tanh", "digitized", "preisach",
                          "bouc-wen", "stop-pi", "menegotto-pinto"}
    # the chain inherits nothing: a declaration is per class, not inherited by subclasses
    assert "probe-pi" not in kinds and "chain" not in kinds
    with pytest.raises(ValueError, match=r"fit kind 'lag' is not available; use one of pi, "):
        estimator_class("lag")


@pytest.mark.parametrize("kind", fit_kinds())
def test_each_declared_estimator_fits_a_model_of_its_own_type(kind: str) -> None:
    """The declaration is true: the estimator's ``model_`` is of the declaring type."""
    t = np.arange(3000) * 1e-3
    u = 4 * np.sin(2 * np.pi * 2 * t) * np.minimum(1, t)
    y = PIModel(0.6, [0.5, 1.0, 1.5], [0.4, 0.3, 0.2])(u) + 0.1
    est = estimator_class(kind)(n_operators=3).fit(u, y)
    assert type(est.model_) is model_class(kind)


def test_a_new_registered_fittable_type_appears_everywhere(probe_registered, tmp_path,
                                                           capsys) -> None:
    assert "probe-pi" in fit_kinds()
    # hyst fit --help and hyst batch fit --help list it
    for argv in (["fit", "--help"], ["batch", "fit", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        assert "probe-pi" in capsys.readouterr().out
    # the web page's fit menu (GET /api/capabilities) lists it
    with TestClient(create_app(Settings(viser_port=0))) as client:
        assert "probe-pi" in client.get("/api/capabilities").json()["fit_kinds"]
    capsys.readouterr()  # the viser banner
    # hyst fit --model probe-pi runs its declared estimator
    t = np.arange(2000) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t)
    y = PIModel(0.7, [0.5, 1.0], [0.5, 0.2])(u)
    csv = tmp_path / "rec.csv"
    np.savetxt(csv, np.column_stack((t, u, y)), delimiter=",", header="t,u,y", comments="")
    out = tmp_path / "m.json"
    code = main(["fit", str(csv), "--model", "probe-pi", "-n", "2", "-o", str(out), "--json"])
    res = capsys.readouterr()
    assert code == 0, res.err
    assert json.loads(res.out)["output"] == str(out)
    assert CountingPIRegressor.fits == 1
    assert load_parameter_set(out).provenance.fit["model"] == "probe-pi"
    # the explorer's fit (web page and viser) goes through the same declaration
    out = fit_recording(Recording(u=u, y=y, t=t), 2, "probe-pi")
    assert out.kind == "probe-pi" and CountingPIRegressor.fits == 2


def test_the_viser_fit_menu_lists_the_registry_kinds(probe_registered) -> None:
    import viser

    from app.gui.controller import SessionView
    from app.services.session.sessions import SessionRegistry
    from app.services.words import type_words

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        reg = SessionRegistry()
        v = SessionView(server.gui, reg, reg.create(), Settings(), notify=lambda *a: None,
                        download=lambda n, b: None, scene=server.scene)
        try:
            # the menu shows the registry's words, each looked up back to its kind
            assert tuple(v.ui.fit_kinds.values()) == fit_kinds()
            assert tuple(v.ui.fit_kind.options) == tuple(type_words(k) for k in fit_kinds())
            assert v.ui.fit_kinds[type_words("probe-pi")] == "probe-pi"
            assert v.ui.fit_kind.value == type_words("pi")
        finally:
            v.close()
    finally:
        server.stop()
