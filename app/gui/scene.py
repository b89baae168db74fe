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

    def hide(self) -> None:
        """Take the state graph off the scene (the model changed to one without it)."""
        for h in self._handles:
            try:
                h.remove()
            except Exception:  # noqa: BLE001 - a handle of a closing tab
                pass
        self._handles = []
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
        if key == self._key:
            return
        self.hide()  # another graph: the last one's nodes, edges and labels go
        raw = np.array([embed(np.asarray(row)) for row in states])
        self._center = raw.mean(axis=0)
        pts = raw - self._center  # centred on the scene origin (camera target)
        self.points = pts
        add = self._handles.append
        add(self.scene.add_point_cloud("/states/nodes", pts.astype(np.float32),
                                       colors=(120, 120, 120), point_size=0.06,
                                       point_shape="circle"))
        up = np.stack((pts[up_i[:, 0]], pts[up_i[:, 1]]), axis=1).reshape(-1, 2, 3)
        down = np.stack((pts[down_i[:, 0]], pts[down_i[:, 1]]), axis=1).reshape(-1, 2, 3)
        for name, seg, color in (("up", up, (31, 119, 180)),
                                 ("down", down + 0.01, (255, 127, 14))):
            if len(seg):
                add(self.scene.add_line_segments(f"/states/{name}", seg.astype(np.float32),
                                                 colors=color, thickness=2.0,
                                                 thickness_units="screen"))
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
        self._key = key
        self._aim_camera(pts)

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
