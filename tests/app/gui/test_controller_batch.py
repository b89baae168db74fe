"""One render of a viser tab (``app.gui.controller``; issue 33, a class of thirty): its
plot's lines cut to the samples the tab's pixels draw, and the plot and its texts sent to
the tab in one batch (one React commit), not message by message."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest
from viser._messages import GuiUpdateMessage

from app.gui.controller import SessionView
from app.services.explore import figures as F
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings


@pytest.fixture(scope="module")
def server() -> Iterator[Any]:
    import viser

    s = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield s
    s.stop()


def _view(server: Any, depth: list[int]) -> SessionView:
    @contextmanager
    def atomic() -> Iterator[None]:
        depth[0] += 1
        try:
            yield
        finally:
            depth[0] -= 1

    reg = SessionRegistry()
    v = SessionView(server.gui, reg, reg.create(), Settings(), scene=server.scene,
                    atomic=atomic)
    assert v.worker.wait_idle(30)
    return v


def test_a_render_sends_its_plot_and_texts_in_one_batch(server: Any,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    depth = [0]
    v = _view(server, depth)
    sent: list[tuple[str, tuple[str, ...], bool]] = []
    ws = server.gui._websock_interface
    queue = ws.queue_message

    def record(message: Any) -> None:
        if isinstance(message, GuiUpdateMessage):
            sent.append((message.uuid, tuple(message.updates), depth[0] > 0))
        queue(message)

    monkeypatch.setattr(ws, "queue_message", record)
    try:
        v.ui.param_sliders["weights[0]"].value = 1.2
        assert v.worker.wait_idle(30)
        ui = v.ui
        drawn = {ui.plot._impl.uuid: "plot", ui.status_md._impl.uuid: "status",
                 ui.model_md._impl.uuid: "model", ui.inverse_md._impl.uuid: "inverse"}
        got = [(drawn[u], inside) for u, _, inside in sent if u in drawn]
        assert {"plot", "status", "model"} <= {name for name, _ in got}  # (inverse: if changed)
        assert all(inside for _, inside in got), got
        # the plot itself, once
        assert sum(1 for u, keys, _ in sent if u == ui.plot._impl.uuid
                   and "_plotly_json_str" in keys) == 1
    finally:
        v.close()


def test_the_tabs_plot_is_cut_to_its_pixels(server: Any) -> None:
    """Example 1's loop (670 samples) reaches the tab as about 40, its reversals and its
    extremes exact; ``pixel_cut`` off, every sample."""
    v = _view(server, [0])
    try:
        res = v.last_result
        assert res is not None and v.shown_figure == "loop"
        loop = v.ui.plot.figure.data[0]
        x, y = F.values(loop["x"]), F.values(loop["y"])
        whole = F.build("loop", res).data[0]
        assert F.values(whole["x"]).size == 670
        assert x.size < 100
        assert y.max() == F.values(whole["y"]).max() and x.min() == F.values(whole["x"]).min()
        v.pixel_cut = False
        v._redraw()
        assert v.worker.wait_idle(30)
        assert F.values(v.ui.plot.figure.data[0]["x"]).size == 670
        np.testing.assert_array_equal(F.values(v.ui.plot.figure.data[0]["y"]),
                                      F.values(whole["y"]))
    finally:
        v.close()
