"""Array type aliases used in annotations."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Float1D = npt.NDArray[np.float64]  # shape (N,)
Float2D = npt.NDArray[np.float64]  # shape (N, n)
ArrayLike = npt.ArrayLike

__all__ = ["ArrayLike", "Float1D", "Float2D", "FloatArray"]
