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

Development materials (:data:`DEV_MATERIALS`, the same three OpenSees laws with other
parameters, for rules to be tuned on; the sealed ones above are not):

``os-boucwen-dev``
    ``BoucWen``: post-yield ratio 0.05, initial stiffness 150 MPa per mm/m, n 1, gamma 0.6,
    beta 0.4, A0 1.
``os-steel02-dev``
    ``Steel02``: yield 300 MPa, E0 180 MPa per mm/m, hardening 1 %, R0 15, cR1 0.9,
    cR2 0.1.
``os-pinched-dev``
    ``Hysteretic`` with pinching (pinchX 0.6, pinchY 0.35), envelope 250 MPa at 1.2 mm/m and
    380 MPa at 7 mm/m on both sides, no damage.

:class:`StrainDriven` drives one of them from a voltage-like input (the development
recordings of :mod:`benchmarks.diagnosis.bipolar`, ±150 V -> ±6 mm/m).

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

__all__ = ["DEV_MATERIALS", "MATERIALS", "OpenSeesMaterial", "StrainDriven", "opensees",
           "opensees_available"]


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

#: Development material name -> OpenSees material (the laws of :data:`MATERIALS` with other
#: parameters; rules may be tuned on these).
DEV_MATERIALS: dict[str, OpenSeesMaterial] = {
    "os-boucwen-dev": OpenSeesMaterial("BoucWen", (0.05, 150.0, 1.0, 0.6, 0.4, 1.0, 0.0, 0.0,
                                                   0.0)),
    "os-steel02-dev": OpenSeesMaterial("Steel02", (300.0, 180.0, 0.01, 15.0, 0.9, 0.1)),
    "os-pinched-dev": OpenSeesMaterial("Hysteretic", (250.0, 1.2, 380.0, 7.0, -250.0, -1.2,
                                                      -380.0, -7.0, 0.6, 0.35, 0.0, 0.0, 0.0)),
}


@dataclass
class StrainDriven:
    """A development material of :data:`DEV_MATERIALS` driven by a voltage-like input:
    ``gain * material(strain_per_volt * u)`` (the plant interface of
    :data:`benchmarks.diagnosis.families.BASES`: ``gain`` is set by ``make_base``).

    Parameters
    ----------
    material : str
        A key of :data:`DEV_MATERIALS`.
    strain_per_volt : float
        Strain (mm/m) per input unit: 0.04 takes ±150 V to ±6 mm/m.
    gain : float
        Output per MPa.
    """

    material: str
    strain_per_volt: float = 0.04
    gain: float = 1.0

    def __call__(self, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        """The output along input ``u`` (shape ``(n,)``), from the virgin state."""
        law = DEV_MATERIALS[self.material]
        return self.gain * law(self.strain_per_volt * np.asarray(u, dtype=np.float64))
