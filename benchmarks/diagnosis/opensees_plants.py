"""Truth plants from an independent implementation: OpenSees uniaxial materials.

The sealed set (:mod:`benchmarks.diagnosis.sealed`) must include plants that nobody in this
project wrote. OpenSees (through ``openseespy``, a dev extra) integrates a uniaxial material
along a strain history: ``stress = material(strain)``, rate-independent, and its loops run
clockwise in the (strain, stress) plane, the other way round from a piezo loop.

Materials (:data:`MATERIALS`; strain in units of 1e-3 (mm/m), stress in MPa):

``os-boucwen``
    ``BoucWen`` (smooth, Baber-Noori without degradation): post-yield ratio 0.1, initial
    stiffness 200 MPa per mm/m, n 1.5, gamma = beta = 0.5, A0 1.
``os-steel02``
    ``Steel02`` (Giuffre-Menegotto-Pinto): yield 400 MPa, E0 200 MPa per mm/m, hardening
    2 %, R0 18, cR1 0.925, cR2 0.15.
``os-pinched``
    ``Hysteretic`` with pinching (pinchX 0.8, pinchY 0.2), envelope 300 MPa at 1.5 mm/m and
    420 MPa at 6 mm/m on both sides, no damage.

``openseespy`` is imported only when a material runs (:func:`opensees`), so nothing here is
needed to import ``core`` or this module. The Linux wheel ships ``libblas.so.3`` beside its
``liblapack.so.3`` without a search path between them; :func:`opensees` loads it first.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["MATERIALS", "OpenSeesMaterial", "opensees", "opensees_available"]


def opensees() -> Any:
    """The ``openseespy.opensees`` module (ImportError with the install hint if absent)."""
    spec = importlib.util.find_spec("openseespylinux")
    if spec is not None and spec.origin:
        blas = os.path.join(os.path.dirname(spec.origin), "lib", "libblas.so.3")
        if os.path.exists(blas):  # liblapack.so.3 of the wheel needs it and cannot find it
            ctypes.CDLL(blas, mode=ctypes.RTLD_GLOBAL)
    try:
        import openseespy.opensees as ops
    except (ImportError, RuntimeError) as exc:
        raise ImportError("the sealed benchmark's OpenSees plants need openseespy: "
                          "pip install -e '.[dev]' (or pip install openseespy)") from exc
    return ops


def opensees_available() -> bool:
    """Whether :func:`opensees` imports."""
    try:
        opensees()
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class OpenSeesMaterial:
    """One OpenSees uniaxial material driven by a strain history.

    Parameters
    ----------
    kind : str
        OpenSees material type (``"BoucWen"``, ``"Steel02"``, ``"Hysteretic"``).
    args : tuple of float
        Its parameters after the tag, in OpenSees order.
    """

    kind: str
    args: tuple[float, ...]

    def __call__(self, strain: np.ndarray, dt: float | None = None) -> np.ndarray:
        """Stress (MPa) along ``strain`` (mm/m, shape ``(n,)``), from the virgin state."""
        ops = opensees()
        ops.wipe()
        ops.uniaxialMaterial(self.kind, 1, *self.args)
        ops.testUniaxialMaterial(1)
        strain = np.asarray(strain, dtype=np.float64)
        out = np.empty(strain.size)
        for k, e in enumerate(strain):
            ops.setStrain(float(e))
            out[k] = ops.getStress()
        ops.wipe()
        return out


#: Material name -> OpenSees material (strain in mm/m, stress in MPa).
MATERIALS: dict[str, OpenSeesMaterial] = {
    "os-boucwen": OpenSeesMaterial("BoucWen", (0.1, 200.0, 1.5, 0.5, 0.5, 1.0, 0.0, 0.0, 0.0)),
    "os-steel02": OpenSeesMaterial("Steel02", (400.0, 200.0, 0.02, 18.0, 0.925, 0.15)),
    "os-pinched": OpenSeesMaterial("Hysteretic", (300.0, 1.5, 420.0, 6.0, -300.0, -1.5,
                                                  -420.0, -6.0, 0.8, 0.2, 0.0, 0.0, 0.0)),
}
