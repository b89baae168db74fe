"""The non-PI truth plants of benchmarks/diagnosis/families.py against independent
properties (rate independence, wiping out, non-congruent minor loops, closing loops,
saturating stiffness) and the parameter-recovery score."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import (
    BASES,
    STROKE,
    make_base,
    make_family,
    parameter_recovery,
    wrong_names_base,
)
from benchmarks.diagnosis.generator import truth_pi


def _path(nodes: list[float], per_volt: float) -> np.ndarray:
    """Piecewise-linear input through ``nodes`` (every reversal is a sample)."""
    parts = [np.array([nodes[0]])]
    for a, b in zip(nodes[:-1], nodes[1:], strict=True):
        n = max(1, round(abs(b - a) * per_volt))
        parts.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(parts)


NODES = [0.0, 120.0, 30.0, 100.0, 50.0, 150.0, 10.0, 80.0, 60.0]


@pytest.mark.parametrize("name", list(BASES))
def test_rate_independent_and_scaled(name: str) -> None:
    p = make_base(name)
    coarse, fine = _path(NODES, 0.5), _path(NODES, 1.0)
    assert fine.size == 2 * coarse.size - 1  # fine = coarse with a sample between each pair
    y_c, y_f = p(coarse, dt=1e-3), p(fine, dt=1e-3)
    np.testing.assert_allclose(y_f[::2], y_c, atol=1e-3)  # um, on a 100 um stroke
    # the time step does not matter either (rate-independent)
    np.testing.assert_allclose(p(coarse, dt=1e-5), y_c, atol=1e-12)
    sweep = np.concatenate((np.linspace(0, 150, 301), np.linspace(150, 0, 301)))
    assert np.ptp(p(sweep)) == pytest.approx(STROKE, rel=1e-6)


def test_preisach_wiping_out_and_non_congruent_minor_loops() -> None:
    p = make_base("preisach")
    # wiping out: 90 V erases the 80 / 50 V reversal pair
    a = p(_path([0.0, 100.0, 30.0, 80.0, 50.0, 90.0], 4.0))
    b = p(_path([0.0, 100.0, 30.0, 90.0], 4.0))
    assert a[-1] == pytest.approx(b[-1], abs=1e-12)
    c = p(_path([0.0, 100.0, 30.0, 80.0, 50.0, 75.0], 4.0))
    assert abs(c[-1] - p(_path([0.0, 100.0, 30.0, 75.0], 4.0))[-1]) > 1e-3  # 75 < 80: kept

    def minor_height(plant, bias: float) -> float:
        u = _path([0.0, 150.0, bias + 15, bias - 15, bias + 15, bias - 15, bias + 15], 4.0)
        y = plant(u)
        bottom = u.size - 1 - 120  # the last reversal (30 V at 4 samples per volt)
        assert u[bottom] == pytest.approx(bias - 15)
        return float(y[-1] - y[bottom])  # height of the last ascending minor branch

    lo, hi = minor_height(p, 40.0), minor_height(p, 110.0)
    assert abs(lo - hi) / max(lo, hi) > 0.1  # bias-dependent density: not congruent
    pi = truth_pi()  # control: the PI's minor loops of equal amplitude are congruent
    assert minor_height(pi, 40.0) == pytest.approx(minor_height(pi, 110.0), rel=1e-9)


@pytest.mark.parametrize("name", ["bouc-wen-1", "bouc-wen-2", "bouc-wen-3"])
def test_bouc_wen_loop_closes_on_periodic_input(name: str) -> None:
    p = make_base(name)
    n = 400
    u = 75.0 - 75.0 * np.cos(2 * np.pi * np.arange(6 * n + 1) / n)
    y = p(u)
    assert np.max(np.abs(y[5 * n:] - y[4 * n:5 * n + 1])) < 1e-3 * STROKE  # closed
    assert abs(y[5 * n + n // 4] - y[5 * n + 3 * n // 4]) > 0.05 * STROKE  # hysteretic


def test_maxwell_slip_stiffness_drops_after_all_elements_slip() -> None:
    p = make_base("maxwell-slip")
    u = np.concatenate((np.linspace(0, 150, 1501), np.linspace(150, 0, 1501)[1:]))
    y = p(u)
    down = np.diff(y[1500:]) / np.diff(u[1500:])  # tangent stiffness on the way down
    k_all, k_slid = p.gain * (p.k0 + sum(p.k)), p.gain * p.k0
    assert down[0] == pytest.approx(k_all, rel=1e-9)  # every element sticks after reversal
    assert down[-1] == pytest.approx(k_slid, rel=1e-9)  # all slide after 2 max(d) travel
    assert np.all(np.diff(down) <= 1e-12)  # monotone softening: a saturating branch
    # travel beyond 2 * max(d): stiffness stays at k0
    assert np.allclose(down[int(20 * 2 * max(p.d)):], k_slid)


def test_family_scenario_and_recovery_score() -> None:
    sc = make_family("duhem", "delay", "large", seed=3)
    assert [r.name for r in sc.records] == ["slow", "fast", "decaying", "staircase"]
    assert 60_000 <= sum(r.y.size for r in sc.records) <= 80_000
    assert sc.extras["hidden"] == {"delay": {"delay_s": 1e-3}}
    assert sc.extras["base"] == "duhem"
    again = make_family("duhem", "delay", "large", seed=3)
    assert np.array_equal(sc.records[1].y, again.records[1].y)
    null = make_family("duhem", None, seed=3)
    diff = sc.records[3].y - null.records[3].y
    assert np.median(np.abs(diff)) == 0.0  # same noise; the delay is zero during the holds
    rec = parameter_recovery(
        [{"name": "creep", "parameters": {"taus_s": [0.01, 1.0], "weights": [0.03, 0.02],
                                          "gamma_per_decade": 0.025},
          "uncertainty": {"gamma_per_decade": 0.004}},
         {"name": "lag", "parameters": {"tau_s": 1e-3}}],
        {"creep": {"taus_s": [0.005, 0.1, 5.0], "weights": [0.02] * 3}})
    assert len(rec) == 1 and rec[0]["quantity"] == "creep_total"
    assert rec[0]["found"] == pytest.approx(0.05) and rec[0]["sigma"] == pytest.approx(0.008)
    assert rec[0]["rel_err"] == pytest.approx(-1 / 6) and rec[0]["within"] is False
    assert rec[0]["within_2sigma"] is True  # 0.01 off: beyond 0.008, within 0.016
    assert wrong_names_base(["saturation", "lag", "creep"], ["creep"]) == ["lag"]


def test_family_class_runs_only_when_asked_for() -> None:
    from benchmarks.diagnosis.classes import FAMILY_CASES, FAMILY_CLASS, QUICK, jobs

    assert all(j[0] != FAMILY_CLASS for j in jobs(True))  # the plain --quick is unchanged
    fam = jobs(True, classes=(FAMILY_CLASS,))
    assert len(fam) == len(QUICK[FAMILY_CLASS]) and {j[3] for j in fam} == {500}
    assert set(QUICK[FAMILY_CLASS]) <= set(FAMILY_CASES)
    assert not any(c.split("/")[1] == "rate" and not c.startswith("preisach")
                   for c in FAMILY_CASES)
    # a later run adds seeds: the second round alone is the second half of two rounds
    two = jobs(False, seeds=2, classes=(FAMILY_CLASS,))
    second = jobs(False, seeds=2, classes=(FAMILY_CLASS,), first=1)
    assert second == two[len(two) // 2:] and {j[3] for j in second} == {501}


def test_three_effect_family_is_the_stages_in_order_and_single_effects_unchanged() -> None:
    """A ``a+b+c`` scenario is the base followed by the three truth stages (an independent
    re-composition with ``core.stages``); one effect alone gives the same recordings as
    before the multi-effect form existed (the noise stream, the drift phase)."""
    from core.stages import Asymmetry, Creep, Resonance

    sc = make_family("maxwell-slip", "creep+resonance+asymmetry", "large", seed=4)
    assert set(sc.extras["hidden"]) == {"creep", "resonance", "asymmetry"}
    null = make_family("maxwell-slip", None, seed=4)
    plant = make_base("maxwell-slip")
    rec = sc.records[1]
    y = plant(rec.u)
    y = Asymmetry([1.5, 0.0], 0.5 * STROKE, 0.525 * STROKE)(y)
    y = Creep([0.005, 0.1, 5.0], [0.02] * 3)(y, dt=rec.dt)
    y = Resonance(200.0, 0.05)(y, dt=rec.dt)
    noise = null.records[1].y - plant(rec.u)  # same seed: same noise
    np.testing.assert_allclose(rec.y, y + noise, atol=1e-9)
    one = make_family("maxwell-slip", "delay", "eighth", seed=4)
    assert one.extras["hidden"] == {"delay": {"delay_s": 1e-3 / 8}}
    with pytest.raises(ValueError, match="no size"):
        make_family("maxwell-slip", "creep", "eighth")
    with pytest.raises(ValueError, match="unknown effect"):
        make_family("maxwell-slip", "offset")  # only inside a combination


def test_lookalike_verdict() -> None:
    from benchmarks.diagnosis.classes import lookalike_verdict

    def row(found, amb=(), hidden=("creep", "resonance", "asymmetry"), base=None):
        return {"class": "three effects", "hidden": list(hidden), "found": list(found),
                "claims": [{"name": n, "ambiguous_with": list(amb) if n == found[0] else []}
                           for n in found], "ambiguous": [],
                "extras": {"base": base} if base else {}}

    assert lookalike_verdict(row(["resonance", "asymmetry", "creep"]))[0] == "named"
    v, per = lookalike_verdict(row(["delay", "asymmetry", "creep"], amb=("resonance",)))
    assert v == "flagged" and per["resonance"] == "flagged"
    assert lookalike_verdict(row(["delay", "asymmetry", "creep"]))[0] == "wrong"
    assert lookalike_verdict(row(["asymmetry", "creep"]))[0] == "missed"
    # on a non-PI base a loop-shape name is the base difference, not a wrong name
    assert lookalike_verdict(row(["saturation", "delay"], hidden=("delay",),
                                 base="preisach"))[0] == "named"


def test_family_matrix_counts_first_names_and_clean_nulls_per_base_and_effect() -> None:
    """Hand-counted rows: a run counts for its effect when its first name is hidden; a null
    counts as clean when it names no dynamic or time effect."""
    from benchmarks.diagnosis.classes import family_matrix

    def row(case: str, hidden: list[str], found: list[str], seed: int) -> dict:
        return {"case": case, "hidden": hidden, "found": found, "seed": seed,
                "noise": "white1", "class": "non-PI base", "claims": [], "ambiguous": []}

    rows = [row("duhem/null", [], [], 500), row("duhem/null", [], ["lag"], 501),
            row("duhem/creep/large", ["creep"], ["creep"], 500),
            row("duhem/creep/small", ["creep"], ["saturation", "creep"], 501),
            row("duhem/lag/large", ["lag"], ["lag"], 500)]
    out = family_matrix(rows)
    assert "| duhem | 1/2 | 1/2 | 1/1 | 2/3 |" in out
    assert "top-1 2/3 effect runs over seeds 500, 501" in out


def test_honesty_table_counts_coverage_at_one_and_two_sigma() -> None:
    """Hand-counted recovery rows: 0.5, 1.5 and 3 sigmas off (one of them said ambiguous)
    and one without a sigma."""
    from benchmarks.diagnosis.classes import honesty_table

    def q(quantity: str, found: float, sigma: float | None, amb: bool = False) -> dict:
        return {"quantity": quantity, "truth": 1.0, "found": found, "sigma": sigma,
                "ambiguous": amb}

    rows = [{"recovery": [q("delay_s", 1.05, 0.1), q("delay_s", 1.15, 0.1)]},
            {"recovery": [q("damping", 1.3, 0.1, amb=True), q("damping", 1.01, None)]}]
    out = honesty_table(rows)
    assert "| delay_s | 2 | 1 (50 %) | 2 (100 %) | 0 | 1 (50 %) |" in out
    assert "| damping | 2 | 0 (0 %) | 0 (0 %) | 1 | 1 (50 %) |" in out
    assert "| all | 4 | 1 (25 %) | 2 (50 %) | 1 | 2 (50 %) |" in out
    assert honesty_table([{"recovery": []}]) == ""


def _mp_path(nodes: list[float], step: float) -> np.ndarray:
    """Piecewise-linear strain through ``nodes`` with increments of about ``step``."""
    parts = [np.array([nodes[0]])]
    for a, b in zip(nodes[:-1], nodes[1:], strict=True):
        n = max(1, round(abs(b - a) / step))
        parts.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(parts)


def _meet(er: float, sr: float, d: float, e0: float, fy: float, b: float) -> tuple[float, float]:
    """Where the elastic line from ``(er, sr)`` meets the hardening asymptote of direction
    ``d`` (the line of slope ``b e0`` through ``(d fy / e0, d fy)``), solved by numpy."""
    ey = fy / e0
    a = np.array([[e0, -1.0], [b * e0, -1.0]])
    rhs = np.array([e0 * er - sr, b * e0 * d * ey - d * fy])
    x = np.linalg.solve(a, rhs)
    return float(x[0]), float(x[1])


def test_menegotto_pinto_branches_against_their_analytic_properties() -> None:
    from benchmarks.diagnosis.families import MenegottoPinto

    m = MenegottoPinto()
    e0, fy, b = m.e0, m.fy, m.b
    ey = fy / e0
    nodes = [0.0, 6 * ey, -1 * ey, 12 * ey, -20 * ey, 80 * ey]
    eps = _mp_path(nodes, ey / 400)
    sig = m.stress(eps)
    rev = [int(np.argmin(np.abs(eps - v))) for v in nodes]  # reversal samples (nodes)
    assert sig[0] == 0.0
    for k, (i, j) in enumerate(zip(rev[:-1], rev[1:], strict=True)):
        d = 1.0 if eps[j] > eps[i] else -1.0
        er, sr = float(eps[i]), float(sig[i])
        seg_e, seg_s = eps[i : j + 1], sig[i : j + 1]
        # starts at the reversal point with the elastic slope E0
        slope0 = (seg_s[1] - seg_s[0]) / (seg_e[1] - seg_e[0])
        assert slope0 == pytest.approx(e0, rel=2e-3), k
        # bounded by the elastic line from the reversal and the new direction's asymptote,
        # and on the inner side of the opposite asymptote
        elastic = sr + e0 * (seg_e - er)
        hard = d * fy + b * e0 * (seg_e - d * ey)
        other = -d * fy + b * e0 * (seg_e + d * ey)
        tol = 1e-9 * fy
        assert np.all(d * seg_s <= d * elastic + tol), k
        assert np.all(d * seg_s <= d * hard + tol), k
        assert np.all(d * seg_s >= d * other - tol), k
    # far along a long branch the slope tends to b E0 and the stress to the asymptote
    i, j = rev[-2], rev[-1]
    tail = (sig[j] - sig[j - 40]) / (eps[j] - eps[j - 40])
    assert tail == pytest.approx(b * e0, rel=0.02)
    assert sig[j] == pytest.approx(fy + b * e0 * (eps[j] - ey), rel=3e-3)
    # clockwise in strain-stress: the loading branch lies above the unloading one at 0
    up = sig[rev[2] : rev[3]][np.argmin(np.abs(eps[rev[2] : rev[3]]))]
    down = sig[rev[3] : rev[4]][np.argmin(np.abs(eps[rev[3] : rev[4]]))]
    assert up - down > 0.5 * fy


def test_menegotto_pinto_curvature_depends_on_the_previous_excursion() -> None:
    """Non-Masing: a branch after a large plastic excursion is rounder (smaller R) than one
    after a small one, measured on the normalised branch at eps* = 1, where
    sig* = b + (1 - b) / 2^(1/R) grows with R."""
    from benchmarks.diagnosis.families import MenegottoPinto

    m = MenegottoPinto()
    ey = m.fy / m.e0

    def normalised_at_one(peak: float) -> float:
        eps = _mp_path([0.0, peak, -8 * ey], ey / 2000)
        sig = m.stress(eps)
        i = int(np.argmax(eps))
        ea, sa = _meet(float(eps[i]), float(sig[i]), -1.0, m.e0, m.fy, m.b)
        k = i + int(np.argmin(np.abs(eps[i:] - ea)))
        return float((sig[k] - sig[i]) / (sa - sig[i]))

    small, large = normalised_at_one(1.5 * ey), normalised_at_one(8 * ey)
    b = m.b
    r_of = lambda s: np.log(2.0) / np.log((1 - b) / (s - b))  # noqa: E731 - inverse of sig*(1)
    assert r_of(large) < 0.7 * r_of(small)
    assert r_of(small) <= m.r0 + 1e-6


def _bwbn_slope_of_z(m, z: float, s: float, e: float) -> float:
    """dz/dx of the Bouc-Wen-Baber-Noori law written out again from its equations (Baber
    and Noori 1985; Foliente 1995) at ``z`` moving in direction ``s`` with energy ``e``."""
    nu, eta = 1.0 + m.delta_nu * e, 1.0 + m.delta_eta * e
    zu = (m.a / (nu * (m.beta + m.gamma))) ** (1.0 / m.n)
    z1 = m.zeta_s * (1.0 - np.exp(-m.p * e))
    z2 = (m.psi0 + m.delta_psi * e) * (m.lam + z1)
    h = 1.0 - z1 * np.exp(-((z * s - m.q * zu) ** 2) / z2**2)
    return float(h * (m.a - nu * (m.beta * np.sign(s * z) + m.gamma) * abs(z) ** m.n) / eta)


def test_bouc_wen_baber_noori_loop_is_pinched_clockwise_and_closes() -> None:
    from benchmarks.diagnosis.families import BoucWenBaberNoori

    p = make_base("bouc-wen-baber-noori")
    n = 600
    u = 75.0 - 75.0 * np.cos(2 * np.pi * np.arange(5 * n + 1) / n)
    y = p(u)
    # closed from the second cycle on (the energy has switched the pinching fully on)
    assert np.max(np.abs(y[4 * n:] - y[3 * n:4 * n + 1])) < 1e-4 * STROKE
    assert np.max(np.abs(y[2 * n:3 * n + 1] - y[n:2 * n + 1])) < 1e-2 * STROKE
    cyc, uc = y[3 * n:4 * n + 1], u[3 * n:4 * n + 1]
    # clockwise in u-y (a structural element): the loop integral of y du is positive
    assert float(np.sum(0.5 * (cyc[1:] + cyc[:-1]) * np.diff(uc))) > 0.05 * STROKE * 150
    up, down = cyc[: n // 2 + 1], cyc[n // 2:][::-1]  # both on the rising input grid

    def waist(w: np.ndarray) -> float:
        return float(w[n // 4] / w.max())  # width at mid stroke over the widest width

    w = up - down
    assert np.all(w > -1e-9)  # the loading branch above the unloading one everywhere
    # the pinching narrows the loop near zero hysteretic force (mid stroke here) ...
    assert waist(w) < 0.5
    # ... where the same law without pinching (zeta_s = 0) is at its widest
    q = BoucWenBaberNoori(zeta_s=0.0)
    q.gain = p.gain
    yq = q(u)[3 * n:4 * n + 1]
    assert waist(yq[: n // 2 + 1] - yq[n // 2:][::-1]) > 0.95


def test_bouc_wen_baber_noori_slopes_at_reversals_and_in_the_pinch() -> None:
    from benchmarks.diagnosis.families import BoucWenBaberNoori

    m = BoucWenBaberNoori()
    dx = 1e-3
    nodes = [0.0, 60.0, 5.0, 50.0, 20.0, 60.0]
    x = _path(nodes, 1.0 / dx)
    z = m.z(x)
    f = m.force(x)
    e = np.concatenate(([0.0], np.cumsum(0.5 * (z[1:] + z[:-1]) * np.diff(x))))
    rev = [0] + [int(i) + 1 for i in np.nonzero(np.diff(np.sign(np.diff(x))))[0]] + [x.size - 1]
    assert len(rev) == len(nodes)
    k, al = m.k, m.alpha
    # virgin loading: no energy yet, so no pinching: the slope is k (alpha + (1 - alpha) A)
    assert (f[1] - f[0]) / dx == pytest.approx(k * (al + (1 - al) * m.a), rel=1e-3)
    for i, j in zip(rev[1:-1], rev[2:], strict=True):
        s = 1.0 if x[j] > x[i] else -1.0
        # the tangent just after each reversal is the law's slope at the reversal's z
        slope = (f[i + 1] - f[i]) / (x[i + 1] - x[i])
        want = k * (al + (1 - al) * _bwbn_slope_of_z(m, float(z[i]), s, float(e[i])))
        assert slope == pytest.approx(want, rel=2e-3)
        # unloading is stiffer than the loading that came before it (beta > gamma)
        before = (f[i] - f[i - 1]) / (x[i] - x[i - 1])
        assert slope > before
        # in the pinch (z sign(dx) = q z_u) dz/dx drops to (1 - zeta_s) of the unpinched law
        zu = (m.a / (m.beta + m.gamma)) ** (1.0 / m.n)
        seg = slice(i + 1, j)
        kk = i + 1 + int(np.argmin(np.abs(z[seg] * s - m.q * zu)))
        assert abs(z[kk] * s - m.q * zu) < 1e-2
        dzdx = (z[kk + 1] - z[kk - 1]) / (x[kk + 1] - x[kk - 1])
        free = m.a - (m.beta + m.gamma) * abs(z[kk]) ** m.n  # z sign(dx) > 0 there
        assert dzdx == pytest.approx((1 - m.zeta_s) * free, rel=5e-3)
