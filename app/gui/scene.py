"""The digitized PI's state hypercube in a viser 3D scene (paper 000).

Each of the ``n`` digits is one axis direction: a state ``b_n … b_1`` sits at the sum of
the directions of its set digits, so the ``2**n`` states are the vertices of a (projected)
hypercube and the up / down edges of the state graph are its edges. Up to
:data:`FULL_CUBE_DIGITS` digits the whole cube is drawn; beyond, a projected hypercube is a
tangle (128 vertices for 7 digits), so only the states the input visited are drawn, joined
in the order it visited them. Up to :data:`LABEL_MAX_DIGITS` digits every vertex drawn is
labelled; beyond, labels of nearby states piled on each other (the 23 visited states of
paper 001 Example 1's 7 digits), so only the current state is named, beside the red ball
that marks it (as the web page's state diagram on a phone). The camera
looks at the cube from off its diagonal, so no two vertices overlap (000 and 111 of the
three-operator example). A model without a digitized view hides it all (:meth:`StateCube.
hide`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.services.explore.simulation import FULL_GRAPH_DIGITS, Digitized, state_text, visited_path

__all__ = ["CUBE_MAX_DIGITS", "FULL_CUBE_DIGITS", "StateCube", "embed"]

#: Largest number of digits drawn as a 3D hypercube (more: the 2D figure only).
CUBE_MAX_DIGITS = 7
#: Largest number of digits whose vertices get a text label.
LABEL_MAX_DIGITS = 4
#: Largest number of digits drawn as the whole cube (more: the visited states only).
FULL_CUBE_DIGITS = FULL_GRAPH_DIGITS
#: Colours of the up and down edges.
_EDGE = {"up": (31, 119, 180), "down": (255, 127, 14)}


def embed(digits: np.ndarray) -> np.ndarray:
    """3D position of the state with digit row ``digits`` (shape ``(n,)`` of 0/1).

    Up to three digits use the unit axes (a cube); more use directions spread around a
    circle with alternating heights, so every vertex of the projected hypercube is apart.
    """
    n = digits.size
    if n <= 3:
        dirs = np.eye(3)[:n]
    else:
        a = 2 * np.pi * np.arange(n) / n
        dirs = np.column_stack((np.cos(a), np.sin(a), 0.35 * (-1.0) ** np.arange(n)))
    return np.asarray(digits, dtype=float) @ dirs


class StateCube:
    """The state hypercube of one tab's scene, drawn once per digit count.

    Parameters
    ----------
    scene : viser.SceneApi or None
        The tab's scene (``None``: nothing is drawn, e.g. headless tests without one).
    camera : viser.CameraHandle or None
        The tab's camera, aimed at the cube when it is drawn.
    """

    def __init__(self, scene: Any, camera: Any = None) -> None:
        self.scene = scene
        self.camera = camera
        self._key: tuple[int, ...] | None = None
        #: Vertex positions of the drawn cube, shape ``(2**n, 3)`` (centred), or ``None``.
        self.points: np.ndarray | None = None
        self._center = np.zeros(3)
        self._marker: Any = None
        #: The current state's name beside the ball (beyond LABEL_MAX_DIGITS), or None.
        self._marker_label: Any = None
        self._handles: list[Any] = []
        self._nodes: Any = None  # the states' point cloud
        self._lines: dict[str, Any] = {}  # the up and down edges
        self._shown = False  # the nodes are visible (hide() keeps them, invisible)
        self._points: np.ndarray | None = None  # the vertices, kept while hidden
        #: The frame "/states" every node of the graph hangs under: hiding and showing it
        #: hides and shows them all with one message to the tab (was one per node).
        self._root: Any = None

    def hide(self) -> None:
        """Take the state graph out of view (the model changed to one without it): its
        nodes stay in the scene, invisible, to be moved in place and shown again by the
        next graph of their kind (removing them and adding them again made every tab
        compile the scene's shaders again: a lesson's step without a digitized view, then
        one with it, cost a viser tab ~0.3 s of main thread in software WebGL). Only their
        parent frame is hidden: one message to the tab, not one per node."""
        if self._root is not None:
            try:
                self._root.visible = False
            except Exception:  # noqa: BLE001 - a handle of a closing tab
                pass
        self._shown = False
        self.points = None

    def _drop(self) -> None:
        """Remove the state graph's nodes from the scene (another kind of graph comes)."""
        for h in reversed(self._handles):  # a child (the ball's name) before its parent
            try:
                h.remove()
            except Exception:  # noqa: BLE001 - a handle of a closing tab
                pass
        self._handles = []
        self._nodes = None
        self._lines = {}
        self._marker = None
        self._marker_label = None
        self._key = None
        self.points = None

    def draw(self, d: Digitized) -> None:
        """Draw ``d``'s state graph (a no-op when it is already drawn): the whole cube up
        to :data:`FULL_CUBE_DIGITS` digits, the visited states beyond; beyond
        :data:`CUBE_MAX_DIGITS` digits, or without a graph, it is hidden."""
        if self.scene is None:
            return
        g = d.graph
        n = d.model.n
        if (g is None and n <= FULL_CUBE_DIGITS) or n > CUBE_MAX_DIGITS:
            self.hide()
            return
        if n <= FULL_CUBE_DIGITS:
            states, up_i, down_i = g.digits, g.up, g.down
            labels = list(g.strings) if n <= LABEL_MAX_DIGITS else []
        else:
            states, up_i, down_i, _ = visited_path(d.trace.digits)
            labels = [state_text(r) for r in states] if n <= LABEL_MAX_DIGITS else []
        key = (n, np.asarray(states, dtype=np.int8).tobytes())
        if key == self._key:  # the graph drawn (shown again if it was hidden)
            self._show()
            return
        raw = np.array([embed(np.asarray(row)) for row in states])
        center = raw.mean(axis=0)
        pts = raw - center  # centred on the scene origin (camera target)
        up = np.stack((pts[up_i[:, 0]], pts[up_i[:, 1]]), axis=1).reshape(-1, 2, 3)
        down = np.stack((pts[down_i[:, 0]], pts[down_i[:, 1]]), axis=1).reshape(-1, 2, 3)
        if self._same_kind(n, labels):
            # another path of as many digits (a lesson's step with another input): the
            # nodes' and edges' points change in place; removing and adding the nodes made
            # every tab's browser compile the scene's shaders again (software WebGL: ~2 s
            # of a tab's main thread in a class of thirty, issue 33)
            self._center, self.points = center, pts
            self._points = pts
            self._nodes.colors = np.tile(np.uint8(120), (len(pts), 3))
            self._nodes.points = pts.astype(np.float32)
            for name, seg in (("up", up), ("down", down + 0.01)):
                self._place(name, seg)
            self._show()
            self._key = key
            self._aim_camera(pts)
            return
        self._drop()  # another graph: the last one's nodes, edges and labels go
        self._center, self.points = center, pts
        self._points = pts
        if self._root is None:  # kept for the tab's life: the graphs come and go under it
            self._root = self.scene.add_frame("/states", show_axes=False)
        self._root.visible = True
        add = self._handles.append
        self._nodes = self.scene.add_point_cloud("/states/nodes", pts.astype(np.float32),
                                                 colors=(120, 120, 120), point_size=0.06,
                                                 point_shape="circle")
        add(self._nodes)
        self._lines = {}
        for name, seg in (("up", up), ("down", down + 0.01)):
            self._place(name, seg)
        for c, p in zip(labels, pts, strict=False):
            add(self.scene.add_label(f"/states/label_{c}", c, position=tuple(p + 0.06),
                                     font_screen_scale=1.6 if n <= LABEL_MAX_DIGITS else 1.1,
                                     anchor="bottom-left"))
        self._marker = self.scene.add_icosphere("/states/current", radius=0.09,
                                                color=(214, 39, 40))
        add(self._marker)
        self._marker_label = None
        if not labels:  # the current state named beside its ball (a child: it moves along)
            self._marker_label = self.scene.add_label(
                "/states/current/name", "", position=(0.08, 0.08, 0.08),
                font_screen_scale=1.3, anchor="bottom-left")
            add(self._marker_label)
        self._shown = True
        self._key = key
        self._aim_camera(pts)

    def _show(self) -> None:
        """Make the kept nodes visible again (after :meth:`hide`): their parent frame, each
        node keeping its own visibility (an edge without segments stays hidden,
        :meth:`_place`; the ball is moved by :meth:`show_state`, which follows a draw)."""
        if self._shown:
            return
        self.points = self._points
        if self._root is not None:
            self._root.visible = True
        self._shown = True

    def _same_kind(self, n: int, labels: list[str]) -> bool:
        """Whether the graph drawn is a visited path of ``n`` digits without a label per
        state, as the one to draw (its nodes and edges can be moved in place)."""
        return (self._key is not None and self._key[0] == n and n > FULL_CUBE_DIGITS
                and not labels and self._marker_label is not None and self._nodes is not None)

    def _place(self, name: str, seg: np.ndarray) -> None:
        """The ``name`` edges ("up" or "down") at ``seg`` (shape ``(k, 2, 3)``): added the
        first time, then moved in place; hidden while there are none."""
        h = self._lines.get(name)
        if not len(seg):
            if h is not None:
                h.visible = False
            return
        seg = seg.astype(np.float32)
        if h is None:
            h = self.scene.add_line_segments(f"/states/{name}", seg, colors=_EDGE[name],
                                             thickness=2.0, thickness_units="screen")
            self._lines[name] = h
            self._handles.append(h)
            return
        h.colors = np.tile(np.asarray(_EDGE[name], dtype=np.uint8), (len(seg), 2, 1))
        h.points = seg
        h.visible = True

    def show_state(self, digits: np.ndarray) -> None:
        """Move the red ball to the state with digit row ``digits``."""
        if self._marker is not None and self.points is not None:
            self._marker.position = tuple(embed(digits) - self._center)
            self._marker.visible = True
            if self._marker_label is not None:
                self._marker_label.text = state_text(np.asarray(digits))

    def hide_marker(self) -> None:
        """Hide the red ball (no digitized view)."""
        if self._marker is not None:
            self._marker.visible = False

    def _aim_camera(self, pts: np.ndarray) -> None:
        """Look at the cube from off its diagonal, so no two vertices overlap (000/111)."""
        if self.camera is None:
            return
        radius = float(np.max(np.linalg.norm(pts, axis=1))) or 1.0
        direction = np.array([0.55, -1.0, 0.45])
        direction /= np.linalg.norm(direction)
        try:
            self.camera.up_direction = (0.0, 0.0, 1.0)
            # viser moves look_at with the position: set the target afterwards
            self.camera.position = tuple(3.2 * radius * direction)
            self.camera.look_at = (0.0, 0.0, 0.0)
        except Exception:  # noqa: BLE001 - a camera of a closing tab
            pass
