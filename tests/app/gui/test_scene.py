"""The state graph in viser's 3D scene (app/gui/scene.py), drawn into a scene that records
what it was given: paper 001 Example 1's 7 digits name only the current state, beside its
ball, whose name follows the state (the 23 visited states' labels piled on each other in the
tab); four digits name every state drawn."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from app.gui.scene import StateCube
from app.services.explore.config import Config
from app.services.explore.simulation import compute, state_text, visited_path


class _Node:
    def __init__(self, name: str, **props: Any) -> None:
        self.name = name
        self.visible = True
        self.position = props.get("position", (0.0, 0.0, 0.0))
        self.text = props.get("text")

    def remove(self) -> None:
        pass


class _Scene:
    """Keeps every node it is asked for, by name."""

    def __init__(self) -> None:
        self.nodes: dict[str, _Node] = {}

    def _add(self, name: str, **props: Any) -> _Node:
        self.nodes[name] = node = _Node(name, **props)
        return node

    def add_frame(self, name: str, *a: Any, **k: Any) -> _Node:
        return self._add(name)

    def add_point_cloud(self, name: str, *a: Any, **k: Any) -> _Node:
        return self._add(name)

    def add_line_segments(self, name: str, *a: Any, **k: Any) -> _Node:
        return self._add(name)

    def add_icosphere(self, name: str, *a: Any, **k: Any) -> _Node:
        return self._add(name)

    def add_label(self, name: str, text: str, **k: Any) -> _Node:
        return self._add(name, text=text, **k)

    def shown(self, name: str) -> bool:
        """Whether the node ``name`` is seen: it and every parent it has are visible (as a
        viser tab draws it)."""
        parts = name.split("/")
        return all(self.nodes[p].visible for p in ("/".join(parts[:i])
                                                   for i in range(2, len(parts) + 1))
                   if p in self.nodes)

    def labels(self) -> list[_Node]:
        return [n for n in self.nodes.values() if n.text is not None]


def test_seven_digits_name_only_the_current_state() -> None:
    d = compute(Config(), views={"digitized"}).digitized
    assert d is not None and d.model.n == 7
    scene = _Scene()
    cube = StateCube(scene)
    cube.draw(d)
    for k in (0, len(d.trace.sample) // 2, len(d.trace.sample) - 1):
        row = np.asarray(d.trace.digits[k])
        cube.show_state(row)
        (label,) = scene.labels()  # one label: no pile of 23
        assert label.text == state_text(row)
        # a child of the ball's node: drawn beside it wherever it moves
        assert label.name.startswith("/states/current/")


def test_four_digits_name_every_state_drawn() -> None:
    cfg = Config()
    cfg = cfg.with_model({"type": "pi", "p0": 0.5, "thresholds": [1.0, 2.0, 3.0],
                          "weights": [0.5, 0.4, 0.3]})
    d = compute(cfg, views={"digitized"}).digitized
    assert d is not None and d.model.n == 4  # three operators and the linear term
    scene = _Scene()
    StateCube(scene).draw(d)
    states, *_ = visited_path(d.trace.digits)
    assert sorted(n.text for n in scene.labels()) == sorted(state_text(r) for r in states)
    assert len(scene.labels()) > 1


def test_another_path_of_as_many_digits_moves_the_nodes_in_place() -> None:
    """A lesson's step with another input (same model): the nodes and edges are moved, not
    removed and added again (each new node made every viser tab compile its shaders again:
    ~2 s of a tab's main thread in software WebGL, class of thirty, issue 33)."""
    cfg = Config()
    d1 = compute(cfg, views={"digitized"}).digitized
    d2 = compute(replace(cfg, signal=replace(cfg.signal, frequency=cfg.signal.frequency / 2)),
                 views={"digitized"}).digitized
    assert d1 is not None and d2 is not None and d1.model.n == d2.model.n == 7
    scene = _Scene()
    cube = StateCube(scene)
    cube.draw(d1)
    before = dict(scene.nodes)
    cube.draw(d2)
    assert scene.nodes == before  # no node added (nor replaced)
    states, *_ = visited_path(d2.trace.digits)
    assert len(states) != len(visited_path(d1.trace.digits)[0])
    assert len(scene.nodes["/states/nodes"].points) == len(states)
    assert cube.points is not None and len(cube.points) == len(states)


def test_a_step_without_the_graph_keeps_its_nodes_for_the_next() -> None:
    """A lesson's step whose model has no digitized view (*PI basics* step 5, a minor loop
    narrower than the widest operator), then one with it (step 6, another initial memory):
    the state graph is hidden, not removed, and the next graph moves the same nodes in place
    and shows them (removed and added again, every viser tab compiled the scene's shaders
    again at step 6: ~0.3 s of a tab's main thread with one tab alone, issue 33)."""
    cfg = Config()
    d1 = compute(cfg, views={"digitized"}).digitized
    d2 = compute(replace(cfg, signal=replace(cfg.signal, frequency=cfg.signal.frequency / 2)),
                 views={"digitized"}).digitized
    assert d1 is not None and d2 is not None
    scene = _Scene()
    cube = StateCube(scene)
    cube.draw(d1)
    before = dict(scene.nodes)
    cube.hide()
    assert not any(scene.shown(k) for k in scene.nodes)
    assert cube.points is None
    cube.draw(d2)
    assert scene.nodes == before  # the same nodes, none removed nor added
    cube.show_state(d2.trace.digits[-1])
    assert all(scene.shown(k) for k in scene.nodes), {
        k: scene.shown(k) for k in scene.nodes}
    assert cube.points is not None and len(scene.nodes["/states/nodes"].points) == len(
        cube.points)
    cube.hide()
    cube.draw(d2)  # the same graph again: shown as it was
    assert scene.nodes == before and all(scene.shown(k) for k in scene.nodes)
