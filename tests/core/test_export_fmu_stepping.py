"""FMUs stepped the way real importers step them (issue 32), through fmpy's low-level API and a
hand-written C master, FMI 3.0 and 2.0:

- OMSimulator and most masters add up time in floating point (``t += dt``) and end a run to a
  stop time with whatever is left: a step of 5.5e-14 s, or a step a little past a sample;
- ``stepUntil((k + 1) * dt)`` masters split a step at their own accumulated time and so call
  ``doStep`` with a few ulps left over (steps of 4e-19 s);
- Simulink-like fixed-step masters step several samples at once;
- a stop time that is not a whole number of samples ends on a partial sample.

Each loop must reproduce ``model.simulate`` sample for sample (to 1e-12 of the output range):
no sample run twice, none skipped. The FMUs are built once per module (two compensators of a
diagnosed chain, PI -> lag -> delay, one per FMI version).
"""

from __future__ import annotations

import shutil
import subprocess
import warnings
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

from core.export_fmu import build_fmu, fmi_headers, fmu_sources
from core.paramset import ParameterSet, Units
from core.stages import causal_form
from tests.core.model_zoo import DIAGNOSED, DT, turning_points

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from fmpy.fmi3 import FMU3Slave  # noqa: E402

GCC = shutil.which("gcc")
MODEL = DIAGNOSED["diag-lag-delay"]  # its compensator: PI inverse, lag inverse, a delay
TOL = 1e-12  # of the output range


@pytest.fixture(scope="module", params=[3, 2], ids=["fmi3", "fmi2"])
def fmu(request, tmp_path_factory) -> Path:
    if GCC is None:
        pytest.skip("gcc not installed")
    d = tmp_path_factory.mktemp(f"step{request.param}")
    return build_fmu(MODEL, d / "comp.fmu", fmi_version=request.param, inverse=True, dt=DT)


class Master:
    """An importer's side of one FMU instance: fmpy's low-level calls, nothing more."""

    def __init__(self, path: Path, unzip: Path, log: list[str] | None = None,
                 start: bool = True) -> None:
        md = read_model_description(str(path))
        self.v3 = md.fmiVersion.startswith("3")
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        d = extract(str(path), unzipdir=str(unzip))
        cls = FMU3Slave if self.v3 else FMU2Slave
        self.fmu = cls(guid=md.instantiationToken if self.v3 else md.guid, unzipDirectory=d,
                       modelIdentifier=md.coSimulation.modelIdentifier, instanceName="m")
        if log is None:
            self.fmu.instantiate()
        else:
            from tests.core.test_export_fmu import instantiate_logging

            instantiate_logging(self.fmu, self.v3, log)
        self.calls = 0
        if start:
            self.start()

    def start(self) -> None:
        if self.v3:
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def set(self, value: float) -> None:
        (self.fmu.setFloat64 if self.v3 else self.fmu.setReal)([1], [value])

    def get(self) -> float:
        return (self.fmu.getFloat64 if self.v3 else self.fmu.getReal)([2])[0]

    def step(self, t: float, h: float) -> None:
        self.fmu.doStep(t, h)
        self.calls += 1

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


def _reference(u: np.ndarray, per: int = 1) -> np.ndarray:
    """Python: the compensator's causal form on ``u`` held ``per`` samples, the output at the
    last sample of each hold."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        y = causal_form(MODEL.inverse(), DT).model(np.repeat(u, per), dt=DT)
    return y[per - 1::per]


def _desired(seed: int, n: int) -> np.ndarray:
    return MODEL(turning_points(seed, n), dt=DT)  # inside the forward model's range


def _close(y: np.ndarray, ref: np.ndarray) -> None:
    scale = max(1.0, float(np.ptp(ref)))
    np.testing.assert_allclose(y, ref, rtol=0, atol=TOL * scale)


def test_accumulated_time_and_a_tiny_last_step_to_the_stop_time(fmu, tmp_path) -> None:
    """``t += dt`` over 4,000 steps, then the step to the stop time: 4,000 * dt is 2.8e-14 s
    beyond the accumulated t, so the last step is that long and runs no sample (before: the
    FMU refused it with an error, so every run to a stop time ended in one)."""
    m = Master(fmu, tmp_path / "x")
    u = _desired(1, 4000)
    y, t = np.empty(u.size), 0.0
    for k, x in enumerate(u.tolist()):
        m.set(x)
        m.step(t, DT)
        t += DT
        y[k] = m.get()
    stop = u.size * DT
    assert 0.0 < stop - t < 1e-13  # the importer's remainder
    m.step(t, stop - t)
    assert m.get() == y[-1]  # no sample in it
    _close(y, _reference(u))
    m.close()


def test_step_until_loops_that_split_steps_at_their_own_time(fmu, tmp_path) -> None:
    """An OMSimulator-like ``stepUntil((k + 1) * dt)``: the master steps ``dt`` from its own
    accumulated time and clips the step at the target, leaving steps of a few ulps (4e-19 s,
    ~18 % of the calls) and steps a few ulps short of ``dt``."""
    m = Master(fmu, tmp_path / "x")
    u = _desired(2, 3000)
    y, t, tiny = np.empty(u.size), 0.0, 0
    for k, x in enumerate(u.tolist()):
        m.set(x)
        target = (k + 1) * DT
        while t < target:
            nxt = min(t + DT, target)
            m.step(t, nxt - t)
            tiny += nxt - t < 1e-6 * DT
            t = nxt
        y[k] = m.get()
    assert tiny > 100  # the loop did make such steps
    _close(y, _reference(u))
    m.close()


@pytest.mark.parametrize("per", [2, 10])
def test_several_samples_per_step_with_accumulated_time(fmu, tmp_path, per) -> None:
    m = Master(fmu, tmp_path / "x")
    u = _desired(3 + per, 600)
    y, t, h = np.empty(u.size), 0.0, per * DT
    for k, x in enumerate(u.tolist()):
        m.set(x)
        m.step(t, h)
        t += h
        y[k] = m.get()
    _close(y, _reference(u, per))
    m.close()


def test_a_stop_time_between_samples_holds_the_remainder(fmu, tmp_path) -> None:
    """Steps of 1.5 samples and a stop 0.37 of a sample past the last sample instant: each
    step runs the samples whose instants it reaches (1, 2, 1, 2, ...), the remainder is held
    and the partial last step runs none."""
    m = Master(fmu, tmp_path / "x")
    u = _desired(4, 1200)
    ys, t, h = [], 0.0, 1.5 * DT
    counts = np.tile([1, 2], u.size // 2)
    held = np.repeat(u, counts)  # the input each sample ran with
    for x in u.tolist():
        m.set(x)
        m.step(t, h)
        t += h
        ys.append(m.get())
    stop = (held.size + 0.37) * DT
    m.step(t, stop - t)
    assert m.get() == ys[-1]
    ref = _reference(held)[np.cumsum(counts) - 1]
    _close(np.array(ys), ref)
    m.close()


_C_MASTER = r"""
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include "fmi3Functions.h"

/* A hand-written master: set y_ref, doStep(t, dt) with t += dt, read u; then the step to the
 * stop time n * dt. Input samples on stdin, outputs on stdout, bad statuses on stderr. */
int main(int argc, char **argv)
{
    void *lib = dlopen(argv[1], RTLD_NOW);
    fmi3InstantiateCoSimulationTYPE *inst;
    fmi3EnterInitializationModeTYPE *enter;
    fmi3ExitInitializationModeTYPE *leave;
    fmi3SetFloat64TYPE *set;
    fmi3GetFloat64TYPE *get;
    fmi3DoStepTYPE *step;
    fmi3Instance c;
    const double dt = atof(argv[3]);
    const fmi3ValueReference in = 1, out = 2;
    double t = 0.0, x, y, stop, last;
    long k = 0, bad = 0;
    fmi3Boolean a, b, e;
    if (!lib || argc < 4) return 2;
    inst = (fmi3InstantiateCoSimulationTYPE *)dlsym(lib, "fmi3InstantiateCoSimulation");
    enter = (fmi3EnterInitializationModeTYPE *)dlsym(lib, "fmi3EnterInitializationMode");
    leave = (fmi3ExitInitializationModeTYPE *)dlsym(lib, "fmi3ExitInitializationMode");
    set = (fmi3SetFloat64TYPE *)dlsym(lib, "fmi3SetFloat64");
    get = (fmi3GetFloat64TYPE *)dlsym(lib, "fmi3GetFloat64");
    step = (fmi3DoStepTYPE *)dlsym(lib, "fmi3DoStep");
    c = inst("m", argv[2], NULL, 0, 0, 0, 0, NULL, 0, NULL, NULL, NULL);
    if (!c || enter(c, 0, 0.0, 0.0, 0, 0.0) || leave(c)) return 3;
    while (fread(&x, sizeof x, 1, stdin) == 1) {
        bad += set(c, &in, 1, &x, 1) != fmi3OK;
        bad += step(c, t, dt, 1, &a, &b, &e, &last) != fmi3OK;
        t += dt;
        bad += get(c, &out, 1, &y, 1) != fmi3OK;
        fwrite(&y, sizeof y, 1, stdout);
        ++k;
    }
    stop = (double)k * dt;
    if (stop > t) bad += step(c, t, stop - t, 1, &a, &b, &e, &last) != fmi3OK;
    fprintf(stderr, "%ld %ld %.17g\n", k, bad, (stop - t) / dt);
    return 0;
}
"""


def test_a_c_master_runs_a_million_accumulated_steps(tmp_path) -> None:
    """1e6 steps of ``t += dt`` in C: the accumulated time ends 2.2e-5 of a sample past the
    stop time (another master's would end short of it); every call is OK and the output is
    Python's sample for sample."""
    if GCC is None:
        pytest.skip("gcc not installed")
    path = build_fmu(MODEL, tmp_path / "c.fmu", fmi_version=3, inverse=True, dt=DT)
    unzip = tmp_path / "x"
    with zipfile.ZipFile(path) as zf:
        zf.extractall(unzip)
    token = read_model_description(str(path)).instantiationToken
    (tmp_path / "master.c").write_text(_C_MASTER)
    exe = tmp_path / "master"
    proc = subprocess.run([GCC, "-std=c99", "-O1", "-I", str(fmi_headers(3)), "-o", str(exe),
                           str(tmp_path / "master.c"), "-ldl"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[:2000]
    n = 1_000_000
    u = np.tile(_desired(5, 50_000), n // 50_000)
    res = subprocess.run([str(exe), str(unzip / "binaries/x86_64-linux/c.so"), token,
                          repr(DT)], input=u.astype("<f8").tobytes(), capture_output=True)
    assert res.returncode == 0, res.stderr
    k, bad, left = res.stderr.decode().split()
    assert (int(k), int(bad)) == (n, 0)
    assert abs(float(left)) > 1e-6  # the accumulated time did drift (here past the stop)
    _close(np.frombuffer(res.stdout, "<f8"), _reference(u))


# ----------------------------------------------------------------------------- bad values
class LoggedMaster(Master):
    """A master whose FMU logs into ``self.log`` (``"<status> <message>"``); started by the
    test (:meth:`start`)."""

    def __init__(self, path: Path, unzip: Path) -> None:
        self.log: list[str] = []
        super().__init__(path, unzip, log=self.log, start=False)

    def set_named(self, values: dict[str, float]) -> None:
        (self.fmu.setFloat64 if self.v3 else self.fmu.setReal)(
            [self.vr[n] for n in values], list(values.values()))

    def get_named(self, name: str) -> float:
        return (self.fmu.getFloat64 if self.v3 else self.fmu.getReal)([self.vr[name]])[0]

    def refused(self, call, *args) -> tuple[int, str]:
        """(status, logged message) of a call that must fail."""
        from fmpy.fmi1 import FMICallException

        n = len(self.log)
        with pytest.raises(FMICallException) as e:
            call(*args)
        assert len(self.log) == n + 1, self.log[n:]
        return e.value.status, self.log[-1]


DISCARD = 2


def test_non_finite_input_is_discarded_and_the_state_kept(fmu, tmp_path) -> None:
    """NaN and infinite inputs are refused (Discard: the FMU is as before the call), the
    previous input is held; an input the model cannot represent (1e308: the lag inverse
    overflows) discards the step and keeps the memory. Before: status OK, NaN outputs, and
    for the chain every later output NaN."""
    m = LoggedMaster(fmu, tmp_path / "x")
    m.start()
    u = _desired(6, 800)
    ran, ys, t = [], [], 0.0  # the input of each sample the FMU ran
    for k, x in enumerate(u.tolist()):
        if k in (100, 300, 500):
            bad = {100: float("nan"), 300: float("inf"), 500: -float("inf")}[k]
            status, msg = m.refused(m.set, bad)
            assert status == DISCARD
            assert f"discard the input y_ref must be a finite number, got {bad:g}; the " \
                   f"previous value {ran[-1]:.17g} is kept" in msg
            m.step(t, DT)  # the master steps anyway: the held input runs
            ran.append(ran[-1])
        elif k == 700:
            m.set(1e308)
            status, msg = m.refused(m.step, t, DT)
            assert status == DISCARD and "the step is not taken" in msg
            assert m.get() == ys[-1]
            if not m.v3:  # how far it got: the end of the last step taken (FMI 2 asks)
                assert m.fmu.getRealStatus(2) == t  # fmi2LastSuccessfulTime
                assert m.fmu.getBooleanStatus(3) is False  # fmi2Terminated
            continue  # no sample ran
        else:
            m.set(x)
            m.step(t, DT)
            ran.append(x)
        t += DT
        ys.append(m.get())
    y = np.array(ys)
    assert np.isfinite(y).all()
    _close(y, _reference(np.array(ran)))
    m.close()


def test_parameters_outside_the_models_rules_are_refused_while_running(fmu, tmp_path) -> None:
    """A zero or negative time constant, a threshold out of order: refused at set time
    (Discard), the message naming the value, the rule and the value kept; values set in one
    call are judged together (all thresholds moved up at once is fine)."""
    m = LoggedMaster(fmu, tmp_path / "x")
    m.start()
    u = _desired(7, 600)
    first = []
    t = 0.0
    for x in u[:300].tolist():
        m.set(x)
        m.step(t, DT)
        t += DT
        first.append(m.get())
    tau = "s1_lag_inverse.tau_s"
    old = m.get_named(tau)
    for bad in (0.0, -1e-3):
        status, msg = m.refused(m.set_named, {tau: bad})
        assert status == DISCARD
        assert f"{tau} = {bad:.17g} is refused: it must be greater than 0; the previous " \
               f"value {old:.17g} is kept" in msg
    assert m.get_named(tau) == old
    r = [m.get_named(f"s2_pi.thresholds[{i}]") for i in (1, 2, 3)]
    status, msg = m.refused(m.set_named, {"s2_pi.thresholds[2]": r[0] * 0.5})
    assert (status, msg.split(" = ")[0]) == (DISCARD, "discard s2_pi.thresholds[2]")
    assert f"must be greater than s2_pi.thresholds[1] = {r[0]:.17g} (the values must " \
        "increase)" in msg
    names = [f"s2_pi.thresholds[{i}]" for i in range(1, 7)]
    r = [m.get_named(n) for n in names]
    m.set_named({n: 1.5 * v for n, v in zip(names, r, strict=True)})  # one call: in order
    m.set_named(dict(zip(names, r, strict=True)))  # and back
    # a refused value in a call takes back the values set before it in the same call
    status, _ = m.refused(m.set_named, {"s2_pi.weights[1]": 0.3, tau: -1.0})
    assert m.get_named("s2_pi.weights[1]") != 0.3
    y = [*first]
    for x in u[300:].tolist():
        m.set(x)
        m.step(t, DT)
        t += DT
        y.append(m.get())
    _close(np.array(y), _reference(u))  # nothing refused changed the run
    m.close()


# ----------------------------------------------------------------------------- description
def _description(v: int, units: Units, model=MODEL, inverse: bool = True) -> ET.Element:
    src = fmu_sources(ParameterSet.from_model(model, units=units), fmi_version=v,
                      inverse=inverse, dt=DT, name="comp")
    return ET.fromstring(src.model_description)


def _variables(root: ET.Element) -> dict[str, dict[str, str]]:
    """name -> attributes of the variable and of its FMI 2 ``Real`` element."""
    out = {}
    for e in root.iter():
        if e.tag in ("Float64", "ScalarVariable"):
            real = e.find("Real")
            out[e.get("name")] = {**e.attrib, **(real.attrib if real is not None else {})}
    return out


@pytest.mark.parametrize("version", [3, 2])
def test_a_description_an_engineer_can_read(version) -> None:
    """One ASCII spelling of each unit (µm from a CSV header and um from a preset agree)
    with its SI base unit, units on p0 and the weights, min/max where the model's fields
    declare hard limits, sample_time a fixed parameter, preview_samples a calculated one,
    a plain modelName. Before: µm and um, no BaseUnit, no min/max, p0 without unit,
    sample_time and preview_samples local constants, modelName 'comp (inverse compensator)'."""
    root = _description(version, Units(input="V", output="µm"))
    assert ET.tostring(root) == ET.tostring(_description(version, Units(input="V",
                                                                       output="um")))
    assert root.get("modelName") == "comp"
    units = {u.get("name"): u.find("BaseUnit") for u in root.iter("Unit")}
    assert set(units) == {"um", "V", "V/um", "s"}
    assert (units["um"].get("m"), float(units["um"].get("factor"))) == ("1", 1e-6)
    assert {k: units["V"].get(k) for k in ("kg", "m", "s", "A")} == \
        {"kg": "1", "m": "2", "s": "-3", "A": "-1"}
    assert float(units["V/um"].get("factor")) == pytest.approx(1e6, rel=1e-15)
    assert units["s"].attrib == {"s": "1"}
    var = _variables(root)
    assert (var["y_ref"]["unit"], var["u"]["unit"]) == ("um", "V")
    assert var["s2_pi.p0"]["unit"] == "V/um" and var["s2_pi.weights[1]"]["unit"] == "V/um"
    assert var["s2_pi.thresholds[1]"]["unit"] == "um"
    tau = var["s1_lag_inverse.tau_s"]
    assert (tau["unit"], tau["min"], "max" in tau) == ("s", "0.0", False)
    assert "must be > 0" in tau["description"]
    assert "min" not in var["s2_pi.weights[1]"]  # a PI inverse's weights are negative
    st = var["sample_time"]
    assert (st["causality"], st["variability"], float(st["start"])) == \
        ("parameter", "fixed", DT)
    pv = var["preview_samples"]
    assert (pv["causality"], pv["variability"], "start" in pv) == \
        ("calculatedParameter", "fixed", False)


def test_units_without_a_known_base_are_declared_plainly() -> None:
    from core.export_fmu import base_unit, fmi_unit

    assert fmi_unit("µm/V") == "um/V" and fmi_unit("Ω") == "Ohm" and fmi_unit("m²") == "m2"
    assert base_unit("mm") == ({"m": 1}, 1e-3)
    assert base_unit("kPa") == ({"kg": 1, "m": -1, "s": -2}, 1e3)
    assert base_unit("N.m") == ({"kg": 1, "m": 2, "s": -2}, 1.0)
    assert base_unit("1/s") == ({"s": -1}, 1.0)
    for unknown in ("counts", "LSB", "a/b/c", "%", ""):
        assert base_unit(unknown) is None
    root = _description(3, Units(input="counts", output="LSB"), MODEL, inverse=False)
    units = {u.get("name"): u.find("BaseUnit") for u in root.iter("Unit")}
    assert units["counts"] is None and units["LSB"] is None and units["s"] is not None


def test_sample_time_is_fixed_and_refused_steps_say_why(fmu, tmp_path) -> None:
    m = LoggedMaster(fmu, tmp_path / "x")
    m.set_named({"sample_time": DT})  # its own value: fine before initialisation
    status, msg = m.refused(m.set_named, {"sample_time": 2 * DT})
    assert status == 3 and f"sample_time = {2 * DT:.17g} s is fixed at export ({DT:.17g} s" \
        in msg
    m.start()
    assert m.get_named("sample_time") == DT and m.get_named("preview_samples") == 3.0
    status, msg = m.refused(m.step, 0.0, -DT)
    assert status == 3 and f"got {-DT:.17g} s (at t = 0 s; sample_time = {DT:.17g} s)" in msg
    m.close()


def test_weights_that_make_the_compensator_not_an_inverse_are_refused(fmu, tmp_path) -> None:
    """The compensator's PI inverts a PI model only while its slopes q0 + q1 + ... + q_j are
    positive: a weight that makes one non-positive is refused, the values kept."""
    m = LoggedMaster(fmu, tmp_path / "x")
    m.start()
    q0 = m.get_named("s2_pi.p0")
    q = [m.get_named(f"s2_pi.weights[{i}]") for i in range(1, 7)]
    slopes = np.cumsum([q0, *q])
    assert (slopes > 0).all()
    bad = -slopes[2] - 0.1  # slope 4 = slope 3 + q3 would be -0.1
    status, msg = m.refused(m.set_named, {"s2_pi.weights[3]": bad})
    assert status == DISCARD and "s2_pi.p0 .. s2_pi.weights[6]: the slopes of the " \
        "compensator's PI" in msg and f"slope 4 would be {slopes[2] + bad:.17g};" in msg
    assert m.get_named("s2_pi.weights[3]") == q[2]
    m.set_named({"s2_pi.weights[3]": -slopes[2] + 0.1})  # still positive: fine
    m.close()
