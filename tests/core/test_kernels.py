"""Compiled kernels against the numpy oracle (core/reference.py).

The operator matrix and the strict PI output must be bit-identical to the oracle (only
``u ± r``, min/max and a sequential sum are involved); the reassociated fast kernel may
differ at the 1e-16 level and is held to 1e-12 relative.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from core import kernels
from core.reference import pi_output_reference, play_matrix_reference

SETTINGS = settings(max_examples=60, deadline=None)
ROOT = Path(__file__).resolve().parents[2]


@st.composite
def cases(draw):
    """(u, r, w, p0, z0): random input, thresholds >= 0, any weights, any initial state."""
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    N = draw(st.integers(0, 300))
    n = draw(st.integers(1, 40))
    u = np.cumsum(rng.standard_normal(N)) * draw(st.floats(0.01, 10.0))
    r = np.sort(rng.uniform(0.0, 5.0, n))
    if draw(st.booleans()):
        r[0] = 0.0
    w = rng.normal(0.0, 1.0, n)
    z0 = rng.uniform(-5.0, 5.0, n)  # need not be reachable: the kernels clamp it (eq. 2)
    return u, r, w, float(rng.normal()), z0


@SETTINGS
@given(c=cases())
def test_play_matrix_bit_identical_to_oracle(c) -> None:
    u, r, _, _, z0 = c
    out = np.empty((u.size, r.size))
    z = z0.copy()
    kernels.play_matrix(u, r, z, out)
    Yref, zref = play_matrix_reference(u, r, z0)
    assert np.array_equal(out, Yref)
    assert np.array_equal(z, zref if u.size else z0)


@SETTINGS
@given(c=cases())
def test_pi_strict_bit_identical_and_fast_within_1e12(c) -> None:
    u, r, w, p0, z0 = c
    yref, zref = pi_output_reference(u, r, w, p0, z0)
    ys, zs = np.empty(u.size), z0.copy()
    kernels.pi_output_strict(u, r, w, p0, zs, ys)
    assert np.array_equal(ys, yref) and np.array_equal(zs, zref if u.size else z0)
    yf, zf = np.empty(u.size), z0.copy()
    kernels.pi_output_fast(u, r, w, p0, zf, yf)
    assert np.array_equal(zf, zs)  # the state involves no sum: bit-identical as well
    scale = np.abs(p0 * u) + np.abs(np.asarray(play_matrix_reference(u, r, z0)[0])) @ np.abs(w)
    assert np.all(np.abs(yf - yref) <= 1e-12 * np.maximum(scale, 1e-300))


@SETTINGS
@given(c=cases(), S=st.integers(1, 6), seed=st.integers(0, 2**31 - 1))
def test_batch_equals_per_set_evaluation(c, S: int, seed: int) -> None:
    u, r, _, _, _ = c
    n = r.size
    rng = np.random.default_rng(seed)
    R = np.sort(rng.uniform(0.0, 5.0, (S, n)), axis=1)
    W = rng.normal(size=(S, n))
    P0 = rng.normal(size=S)
    Z = rng.uniform(-2, 2, (S, n))
    out = np.empty((S, u.size))
    Zb = Z.copy()
    kernels.pi_batch(u, R, W, P0, Zb, out)
    for s in range(S):
        z = Z[s].copy()
        y = np.empty(u.size)
        kernels.pi_output_fast(u, R[s], W[s], P0[s], z, y)
        yref, zref = pi_output_reference(u, R[s], W[s], P0[s], Z[s])
        assert np.array_equal(Zb[s], z)
        tol = 1e-12 * (np.abs(P0[s] * u) + np.abs(play_matrix_reference(u, R[s], Z[s])[0])
                       @ np.abs(W[s]))
        assert np.all(np.abs(out[s] - y) <= tol)
        assert np.all(np.abs(out[s] - yref) <= tol)


def test_state_in_and_out_allows_chunks() -> None:
    rng = np.random.default_rng(5)
    u = np.cumsum(rng.standard_normal(1000))
    r = np.linspace(0.1, 3.0, 25)
    w = rng.uniform(0, 1, 25)
    y1, z1 = np.empty(u.size), np.zeros(25)
    kernels.pi_output_fast(u, r, w, 0.7, z1, y1)
    z2 = np.zeros(25)
    y2 = np.empty(u.size)
    for a, b in ((0, 1), (1, 333), (333, 333), (333, 1000)):
        kernels.pi_output_fast(u[a:b], r, w, 0.7, z2, y2[a:b])
    assert np.array_equal(y1, y2) and np.array_equal(z1, z2)


def test_kernels_are_compiled_with_on_disk_cache() -> None:
    assert kernels.NUMBA_ENABLED
    for f in (kernels.play_matrix, kernels.pi_output_fast, kernels.pi_output_strict,
              kernels.pi_batch):
        # numba's Dispatcher holds a NullCache unless cache=True
        assert type(f._cache).__name__ == "FunctionCache" and f.targetoptions.get("nogil")
    # only the fast kernels may reassociate; the strict one must not
    assert kernels.pi_output_fast.targetoptions.get("fastmath") == {"reassoc"}
    assert not kernels.pi_output_strict.targetoptions.get("fastmath")


def test_pure_python_fallback_matches_oracle() -> None:
    """HYST_DISABLE_NUMBA=1 runs the same kernel source as plain Python."""
    code = (
        "import numpy as np\n"
        "from core import kernels\n"
        "from core.reference import pi_output_reference\n"
        "assert not kernels.NUMBA_ENABLED\n"
        "rng = np.random.default_rng(1)\n"
        "u = np.cumsum(rng.standard_normal(200)); r = np.linspace(0, 2, 7)\n"
        "w = rng.normal(size=7); z = rng.uniform(-1, 1, 7); z0 = z.copy()\n"
        "y = np.empty(200); kernels.pi_output_strict(u, r, w, 0.4, z, y)\n"
        "yr, zr = pi_output_reference(u, r, w, 0.4, z0)\n"
        "assert np.array_equal(y, yr) and np.array_equal(z, zr)\n"
        "print('ok')\n"
    )
    env = {**os.environ, "HYST_DISABLE_NUMBA": "1"}
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr[-2000:]
