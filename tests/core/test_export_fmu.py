"""FMUs of every registered model type and diagnosed chain, both directions, FMI 3.0 and 2.0,
checked by a real importer (fmpy): validated against the FMI schema, simulated step by step
and compared with the Python models within 1e-9 of the output range, including a tunable
parameter change at t > 0 (the first and the last tunable parameter; reference: the Python
stages with those parameters changed, run on from the state reached) and a reset (reference:
a fresh Python run).

The FMUs are built once per FMI version (module-scoped fixture); each comparison runs
2,000 samples, and one compensator of a diagnosed chain runs 100,000 per version.
"""

from __future__ import annotations

import dataclasses
import functools
import shutil
import subprocess
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

from core.base import Chain, Model
from core.export_c import _flatten, c_identifier
from core.export_fmu import FmuExportError, FmuSources, build_fmu, fmi_headers, fmu_sources
from core.paramset import ParameterSet, ParameterSetError, Units
from core.pi import PIModel
from core.stages import causal_form
from tests.core.model_zoo import DIAGNOSED, DT, EX1, ZOO, turning_points

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from fmpy.fmi3 import FMU3Slave  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

GCC = shutil.which("gcc")
CASES: dict[str, Model] = {**ZOO, **DIAGNOSED}
#: (case, inverse): an advance is only causal as a compensator's preview.
KEYS = [(n, inv) for n in sorted(CASES) for inv in (False, True)
        if not (n == "advance" and not inv)]
N = 2_000
LONG = ("diag-creep-offset", True)  # 100,000 samples: the compensator of a diagnosed chain
N_LONG = 100_000
N_RESET = 500


def _memo_lark(real: type) -> object:
    """``lark.Lark`` for fmpy's check of structured variable names (``validate_fmu``), built
    once per grammar and parsing each name once: a parse is a pure function of the grammar
    and the name, so the check is the same (a name that fails is parsed again and fails
    again). fmpy builds the Earley parser anew for every FMU and parses every name; with
    ~150 FMUs of mostly the same names that was ~40 % of this module's time."""

    @functools.cache
    def parser(grammar: str, start: str) -> object:
        lark_parser = real(grammar, start=start)

        @functools.cache
        def parse(text: str) -> object:
            return lark_parser.parse(text)

        return type("MemoLark", (), {"parse": staticmethod(parse)})()

    def build(grammar: str, start: str = "start", **options: object) -> object:
        return real(grammar, start=start, **options) if options else parser(grammar, start)

    return build


@pytest.fixture(scope="module", autouse=True)
def _parse_each_variable_name_once():
    lark = pytest.importorskip("lark")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(lark, "Lark", _memo_lark(lark.Lark))
        yield


def _dt(model: Model) -> float | None:
    return DT if model.is_dynamic else None


def instantiate_logging(fmu: FMU2Slave | FMU3Slave, v3: bool, log: list[str]) -> None:
    """Instantiate ``fmu`` with a logger appending ``"<status> <message>"`` to ``log`` (FMI 2:
    the FMU passes its message as the format, with no arguments)."""
    def keep(status: int, message: bytes) -> None:
        log.append(f"{('ok', 'warning', 'discard', 'error', 'fatal')[status]} "
                   + message.decode())

    if v3:
        fmu.instantiate(logMessage=lambda env, status, cat, msg: keep(status, msg))
        return
    from fmpy.fmi2 import calloc, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free
    from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE as Alloc
    from fmpy.fmi2 import fmi2CallbackFreeMemoryTYPE as Free

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(lambda env, name, status, cat, msg: keep(status, msg))
    cb.allocateMemory, cb.freeMemory = Alloc(calloc), Free(free)
    fmu._log_callbacks = cb  # alive as long as the instance
    fmu.instantiate(callbacks=cb)


class Slave:
    """An FMU instantiated by fmpy, driven one sample per step (FMI 3 or 2) by a
    ``stepUntil`` loop (a model without dynamics also gets the loop's tiny steps: a repeated
    input sample, which a rate-independent model ignores)."""

    def __init__(self, path: Path, unzip: Path, log: list[str] | None = None) -> None:
        md = read_model_description(str(path))
        self.v3 = md.fmiVersion.startswith("3")
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        # a second instance shares the unzipped library (never overwrite a loaded one)
        d = str(unzip) if (unzip / "modelDescription.xml").exists() else \
            extract(str(path), unzipdir=str(unzip))
        cls = FMU3Slave if self.v3 else FMU2Slave
        self.fmu = cls(guid=md.instantiationToken if self.v3 else md.guid, unzipDirectory=d,
                       modelIdentifier=md.coSimulation.modelIdentifier, instanceName="t")
        if log is None:
            self.fmu.instantiate()
        else:
            instantiate_logging(self.fmu, self.v3, log)
        self.dt = next((v.start for v in md.modelVariables if v.name == "sample_time"), None)
        self.t = 0.0

    def init(self) -> None:
        if self.v3:
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def set(self, name: str, value: float) -> None:
        (self.fmu.setFloat64 if self.v3 else self.fmu.setReal)([self.vr[name]], [value])

    def get(self, name: str) -> float:
        return (self.fmu.getFloat64 if self.v3 else self.fmu.getReal)([self.vr[name]])[0]

    def run(self, u: np.ndarray, h: float = DT) -> np.ndarray:
        set_ = self.fmu.setFloat64 if self.v3 else self.fmu.setReal
        get_ = self.fmu.getFloat64 if self.v3 else self.fmu.getReal
        vin, vout = [1], [2]
        y = np.empty(u.size)
        t0 = self.t
        for k, x in enumerate(u.tolist()):
            set_(vin, [x])
            # as OMSimulator's stepUntil: steps of h from the master's own accumulated time,
            # clipped at the target, which leaves steps of a few ulps (issue 32)
            target = t0 + (k + 1) * h
            while self.t < target:
                nxt = min(self.t + h, target)
                self.fmu.doStep(self.t, nxt - self.t)
                self.t = nxt
            y[k] = get_(vout)[0]
        return y

    def reset(self) -> None:
        self.fmu.reset()
        self.init()

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture(scope="module", params=[3, 2], ids=["fmi3", "fmi2"])
def fmus(request, tmp_path_factory) -> tuple[int, dict[tuple[str, bool], Path]]:
    if GCC is None:
        pytest.skip("gcc not installed")
    from concurrent.futures import ThreadPoolExecutor

    v = request.param
    d = tmp_path_factory.mktemp(f"fmu{v}")

    def build(key: tuple[str, bool]) -> Path:
        name, inv = key
        out = d / f"{c_identifier(name)}_{'inv' if inv else 'fwd'}.fmu"
        return build_fmu(CASES[name], out, fmi_version=v, inverse=inv, dt=_dt(CASES[name]))

    with ThreadPoolExecutor(2) as pool:  # gcc runs in two processes (2 cores)
        return v, dict(zip(KEYS, pool.map(build, KEYS), strict=True))


def _reference(model: Model, inv: bool) -> Model:
    return causal_form(model.inverse(), DT).model if inv else model


def _quiet(model: Model, u: np.ndarray, state=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # inverse maps may clip; the FMU clips the same samples
        return model.simulate(u, state=state, dt=DT)


def _retuned_reference(running: Model, src: FmuSources, values: dict[str, float],
                       u: np.ndarray, k: int) -> np.ndarray:
    """The Python stages on ``u[:k]``, then with the parameters ``values`` changed."""
    stages = _flatten(running)
    states, x = [], u[:k]
    for s in stages:
        r = _quiet(s, x)
        states.append(r.state)
        x = r.y
    first = x
    for name, value in values.items():
        var = next(v for v in src.variables if v.name == name)
        *outer, field = var.path.split(".")
        holder = stages[var.stage]
        for f in outer:
            holder = getattr(holder, f)
        arr = np.array(getattr(holder, field), dtype=np.float64)
        arr.reshape(-1)[var.index] = value
        new = dataclasses.replace(holder, **{field: arr if arr.ndim else float(arr)})
        for f in reversed(outer):  # rebuild the nesting (model.thresholds -> stage.model)
            new = dataclasses.replace(stages[var.stage], **{f: new})
        stages[var.stage] = new
    x = u[k:]
    for s, st in zip(stages, states, strict=True):
        x = _quiet(s, x, st).y
    return np.concatenate([first, x])


@pytest.mark.parametrize("key", KEYS, ids=[f"{n}-{'inv' if i else 'fwd'}" for n, i in KEYS])
def test_fmu_matches_python_with_a_retune_and_a_reset(fmus, key, tmp_path) -> None:
    v, built = fmus
    name, inv = key
    path = built[key]
    assert validate_fmu(str(path)) == []
    model = CASES[name]
    src = fmu_sources(model, fmi_version=v, inverse=inv, dt=_dt(model))
    ref_model = _reference(model, inv)
    n = N_LONG if key == LONG else N
    u = turning_points(KEYS.index(key), n)
    if inv:  # the compensator's input is a desired output: the forward model's range
        u = _quiet(model, u).y if name != "advance" else u
    plain = _quiet(ref_model, u).y
    scale = max(1.0, float(np.ptp(plain)))
    slave = Slave(path, tmp_path / "x")
    slave.init()
    tunable = [p for p in src.parameters() if p.variability == "tunable" and p.start != 0.0]
    k = n // 2
    if tunable:  # the first and the last tunable parameter (of different stages in a chain)
        new = {p.name: p.start * 1.05 for p in (tunable[0], tunable[-1])}
        first = slave.run(u[:k])
        for name, value in new.items():
            slave.set(name, value)
        y = np.concatenate([first, slave.run(u[k:])])
        ref = _retuned_reference(ref_model, src, new, u, k)
        assert np.max(np.abs(ref - plain)[k:]) > 1e-6 * scale, "the change must matter"
        assert [slave.get(n) for n in new] == list(new.values())
    else:
        y, ref = slave.run(u), plain
    np.testing.assert_allclose(y[:k], plain[:k], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-9 * scale)
    with pytest.raises(FMICallException) as refused:  # NaN input: refused, state kept
        slave.set("y_ref" if inv else "u", float("nan"))
    assert refused.value.status == 2  # discard
    slave.reset()  # back to the exported parameters and the initial state
    y2 = slave.run(u[:N_RESET])
    np.testing.assert_allclose(y2, plain[:N_RESET], rtol=0, atol=1e-9 * scale)
    slave.close()


def test_fmu_contents_ports_parameters_and_provenance(tmp_path) -> None:
    ps = ParameterSet.from_model(DIAGNOSED["diag-lag-delay"], source="bench A, run 7",
                                 units=Units(input="V", output="um"))
    src = fmu_sources(ps, fmi_version=3, inverse=True, dt=DT, name="comp")
    assert src.preview == 3
    md = read_model_description(
        str(build_fmu(ps, tmp_path / "comp.fmu", fmi_version=3, inverse=True, dt=DT)))
    by = {v.name: v for v in md.modelVariables}
    assert (by["y_ref"].causality, by["y_ref"].unit) == ("input", "um")
    assert (by["u"].causality, by["u"].unit) == ("output", "V")
    preview = by["preview_samples"]  # derived: a calculated parameter, min = max = 3
    assert (preview.causality, float(preview.min), float(preview.max)) == \
        ("calculatedParameter", 3.0, 3.0)
    assert "preview 3 sample(s)" in md.description and "bench A, run 7" in md.description
    # the compensator runs the stages reversed: delay -> lag -> PI inverse (its last stage)
    w = by["s2_pi.weights[1]"]
    assert (w.causality, w.variability) == ("parameter", "tunable")
    assert by["s2_pi.thresholds[2]"].unit == "um"  # the inverse's thresholds: output units
    assert (by["s2_pi.state0[1]"].variability, float(by["s2_pi.state0[1]"].start)) == ("fixed", 0.0)
    assert by["s1_lag_inverse.tau_s"].unit == "s"
    assert by["s0_delay.delay_s"].variability == "tunable"  # the preview's remainder
    with zipfile.ZipFile(tmp_path / "comp.fmu") as zf:
        names = set(zf.namelist())
        assert {"sources/comp.c", "sources/buildDescription.xml",
                "binaries/x86_64-linux/comp.so", "resources/parameter-set.json"} <= names
        assert ParameterSet.from_json(zf.read("resources/parameter-set.json").decode()
                                      ).provenance.source == "bench A, run 7"
    assert fmpy.model_description.read_build_description(str(tmp_path / "comp.fmu"))


@pytest.mark.parametrize("version", [3, 2])
def test_the_sources_rebuild_strictly(tmp_path, version) -> None:
    """Another platform rebuilds from sources/ with the headers of its importer."""
    if GCC is None:
        pytest.skip("gcc not installed")
    fmu = build_fmu(DIAGNOSED["diag-rate-memory"], tmp_path / "p.fmu", fmi_version=version,
                    inverse=True, dt=DT)
    with zipfile.ZipFile(fmu) as zf:
        (tmp_path / "p.c").write_bytes(zf.read("sources/p.c"))
    proc = subprocess.run([GCC, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O1",
                           "-shared", "-fPIC", "-I", str(fmi_headers(version)), "-o",
                           str(tmp_path / "p.so"), str(tmp_path / "p.c"), "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[:2000]


def test_initial_state_is_a_parameter_set_before_initialisation(tmp_path) -> None:
    fmu = build_fmu(EX1, tmp_path / "pi.fmu", fmi_version=3)
    s = Slave(fmu, tmp_path / "x")
    z0 = [0.3, -0.2, 0.1, 0.0, 0.0, 0.0]
    for i, z in enumerate(z0):
        s.set(f"pi.state0[{i + 1}]", z)
    s.init()
    u = turning_points(5, 600)
    ref = dataclasses.replace(EX1, state0=np.array(z0))(u)
    np.testing.assert_allclose(s.run(u), ref, rtol=0, atol=1e-12)
    with pytest.raises(Exception, match="fmi3SetFloat64"):  # fixed: not while stepping
        s.set("pi.state0[1]", 0.0)
    s.close()


def test_a_step_of_several_samples_holds_the_input_and_bad_steps_are_refused(tmp_path) -> None:
    """Steps of any length are taken (tests/core/test_export_fmu_stepping.py); a negative or
    non-finite one is refused, with the step in the message, and changes nothing."""
    model = ZOO["creep"]
    fmu = build_fmu(model, tmp_path / "c.fmu", fmi_version=2, dt=DT)
    log: list[str] = []
    s = Slave(fmu, tmp_path / "x", log)
    s.init()
    u = turning_points(6, 300)
    y = s.run(u, h=3 * DT)
    np.testing.assert_allclose(y, model(np.repeat(u, 3), dt=DT)[2::3], rtol=0, atol=1e-12)
    for h in (-DT, float("nan"), float("inf")):
        with pytest.raises(Exception, match="fmi2DoStep"):
            s.fmu.doStep(s.t, h)
    assert "the communication step must be a finite number of seconds >= 0, got -0.0001 s" \
        in log[0]
    assert s.get("y") == y[-1]
    s.close()


def test_a_parameter_fixed_at_export_cannot_be_set(tmp_path) -> None:
    fmu = build_fmu(ZOO["lti"], tmp_path / "l.fmu", fmi_version=3, dt=DT)
    s = Slave(fmu, tmp_path / "x")
    with pytest.raises(Exception, match="fmi3SetFloat64"):  # a balanced realisation
        s.set("lti.num[1]", 1e-3)
    s.close()


def test_a_delay_retunes_within_its_whole_samples(tmp_path) -> None:
    """The whole samples of a delay size its buffer: a new fraction is taken, another
    number of samples is refused (and the old delay kept)."""
    from core.stages import Delay

    fmu = build_fmu(Delay(2.5e-4), tmp_path / "d.fmu", fmi_version=2, dt=DT)
    s = Slave(fmu, tmp_path / "x")
    s.init()
    u = turning_points(11, 400)
    first = s.run(u[:200])
    s.set("delay.delay_s", 2.9e-4)
    with pytest.raises(Exception, match="fmi2SetReal"):
        s.set("delay.delay_s", 5e-4)
    assert s.get("delay.delay_s") == 2.9e-4
    y = np.concatenate([first, s.run(u[200:])])
    r1 = Delay(2.5e-4).simulate(u[:200], dt=DT)
    ref = np.concatenate([r1.y, Delay(2.9e-4).simulate(u[200:], state=r1.state, dt=DT).y])
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-12)
    s.close()


def test_bad_options_get_clear_errors(tmp_path, monkeypatch) -> None:
    with pytest.raises(FmuExportError, match=r"unknown FMI version 4; choose 3 or 2"):
        fmu_sources(EX1, fmi_version=4)
    with pytest.raises(FmuExportError, match=r"has dynamics.*--dt 1e-4"):
        fmu_sources(ZOO["creep"])
    with pytest.raises(FmuExportError, match="positive number of seconds"):
        fmu_sources(ZOO["creep"], dt=-1.0)
    monkeypatch.setenv("CC", "no-such-cc")
    with pytest.raises(FmuExportError, match=r"compiler 'no-such-cc' was not found.*install gcc"):
        build_fmu(PIModel(1.0, [0.5], [0.2]), tmp_path / "x.fmu")
    monkeypatch.setattr("importlib.util.find_spec", lambda name: None)
    with pytest.raises(FmuExportError, match="pip install fmpy"):
        fmi_headers(3)


def test_free_text_of_the_parameter_set_cannot_break_the_model_description(tmp_path) -> None:
    """Provenance is free text (markup, quotes, control characters); units are not: the
    unit grammar refuses such a unit at load time (issue 35)."""
    evil = 'a"<b>&\x01\x00\ud800]]>'
    with pytest.raises(ParameterSetError, match=r"^units\.input: has characters"):
        Units(input=evil)
    ps = ParameterSet.from_model(EX1, source=evil, units=Units(input="µm/V", output="µm",
                                                               time="s"))
    fmu = build_fmu(ps, tmp_path / "e.fmu", fmi_version=2, inverse=True)
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert {v.name: v.unit for v in md.modelVariables}["u"] == "um/V"  # the ASCII spelling
    assert 'a"<b>&??' in md.description


def test_two_instances_of_one_library_keep_their_own_parameters(tmp_path) -> None:
    """Two instances in one process (one shared library): each runs its own parameters
    (the constants live in the instance, the model code reads them through a pointer set at
    each call)."""
    model = DIAGNOSED["diag-creep-offset"]
    fmu = build_fmu(model, tmp_path / "c.fmu", fmi_version=3, dt=DT)
    a, b = Slave(fmu, tmp_path / "x"), Slave(fmu, tmp_path / "x")  # same unzipped library
    assert a.fmu.dll._handle == b.fmu.dll._handle  # one library: its globals are shared
    b.set("s0_pi.p0", 0.9)
    a.init()
    b.init()
    u = turning_points(7, 400)
    ya, yb = np.empty(u.size), np.empty(u.size)
    for k in range(u.size):  # interleaved steps
        ya[k] = a.run(u[k:k + 1])[0]
        yb[k] = b.run(u[k:k + 1])[0]
    stages = _flatten(model)
    other = Chain.of(dataclasses.replace(stages[0], p0=0.9), *stages[1:])
    np.testing.assert_allclose(ya, model(u, dt=DT), rtol=0, atol=1e-12)
    np.testing.assert_allclose(yb, other(u, dt=DT), rtol=0, atol=1e-12)
    b.close()
    a.close()


@pytest.mark.parametrize("version", [3, 2])
def test_a_value_that_breaks_the_coefficients_is_refused_and_the_old_one_kept(
        tmp_path, version) -> None:
    model = ZOO["digitized"]
    fmu = build_fmu(model, tmp_path / "d.fmu", fmi_version=version)
    s = Slave(fmu, tmp_path / "x")
    s.init()
    u = turning_points(8, 300)
    y1 = s.run(u[:150])
    tiny = 1e-320  # > 0 as the field requires, but the slope dy/dx overflows
    for bad in (0.0, tiny):  # 0 breaks the field's rule (> 0), tiny the coefficients
        with pytest.raises(Exception, match="Set"):
            s.set("digitized.dx[1]", bad)
    assert s.get("digitized.dx[1]") == float(model.dx[0])
    y = np.concatenate([y1, s.run(u[150:])])
    np.testing.assert_allclose(y, model(u), rtol=0, atol=1e-12)
    s.fmu.reset()  # before initialisation the rule is checked; the coefficients at exit
    with pytest.raises(Exception, match="Set"):
        s.set("digitized.dx[1]", 0.0)
    s.set("digitized.dx[1]", tiny)
    with pytest.raises(Exception, match="ExitInitializationMode"):
        (s.fmu.enterInitializationMode(startTime=0.0) if version == 3 else
         (s.fmu.setupExperiment(startTime=0.0), s.fmu.enterInitializationMode()))
        s.fmu.exitInitializationMode()
    s.fmu.terminate()
    s.fmu.freeInstance()


@pytest.mark.parametrize("degree", [1, 2, 4])
def test_retuned_asymmetry_inverse_finds_the_monotone_range_as_python(tmp_path, degree) -> None:
    """The FMU recomputes the range the inverse clips to (roots of the map's derivative,
    in C) when its coefficients are tuned: random maps, bounded and unbounded ranges."""
    from core.stages import AsymmetryInverse

    fmu = build_fmu(AsymmetryInverse(np.full(degree, 0.01), 0.0, 1.0), tmp_path / "a.fmu",
                    fmi_version=3)
    s = Slave(fmu, tmp_path / "x")
    rng = np.random.default_rng(degree)
    u = 4.0 * turning_points(degree, 800) / 3.0
    bounded = 0  # samples clipped by Python
    for _ in range(6):
        coef, ctr, scale = rng.normal(0.0, 0.4, degree), rng.normal(0.0, 0.3), rng.uniform(0.5, 2)
        ref_model = AsymmetryInverse(coef, ctr, scale)
        lo, hi = ref_model.forward.monotone_range()
        ends = ref_model.forward(np.array([lo if np.isfinite(lo) else 0.0,
                                           hi if np.isfinite(hi) else 0.0]))
        bounded += int(np.sum((np.isfinite(lo) & (u < ends[0]))
                              | (np.isfinite(hi) & (u > ends[1]))))
        s.fmu.reset()
        for i, v in enumerate(coef):
            s.set(f"asymmetry_inverse.coefficients[{i + 1}]", v)
        s.set("asymmetry_inverse.center", ctr)
        s.set("asymmetry_inverse.scale", scale)
        s.init()
        ref = _quiet(ref_model, u).y
        np.testing.assert_allclose(s.run(u), ref, rtol=0, atol=1e-9 * max(1.0, np.ptp(ref)))
    assert bounded > 0  # samples outside a bounded range: the clipping ends were tested
    s.close()


def test_instances_in_two_threads_keep_their_own_parameters(tmp_path) -> None:
    """ctypes releases the GIL in each FMI call, so two threads step their instances of one
    library at the same time: each must see its own constants (thread-local pointer; with a
    process-wide pointer instead this failed in 3 of 5 runs, with it in none of 8)."""
    import threading

    model = ZOO["rate-inverse"]  # a bisection per sample: long calls, wide windows for a race
    fmu = build_fmu(model, tmp_path / "g.fmu", fmi_version=2, dt=DT)
    slaves = [Slave(fmu, tmp_path / "x"), Slave(fmu, tmp_path / "x")]
    slaves[1].set("rate_inverse.p0", 1.5)
    for s in slaves:
        s.init()
    u = turning_points(9, 3000)
    out: dict[int, np.ndarray] = {}
    threads = [threading.Thread(target=lambda i=i: out.__setitem__(i, slaves[i].run(u)))
               for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    other = dataclasses.replace(model, p0=1.5)
    np.testing.assert_allclose(out[0], model(u, dt=DT), rtol=0, atol=1e-9)
    np.testing.assert_allclose(out[1], other(u, dt=DT), rtol=0, atol=1e-9)
    for s in slaves:
        s.close()


@pytest.mark.parametrize("version", [3, 2])
def test_an_importer_rebuilds_the_binary_from_the_sources(tmp_path, monkeypatch,
                                                          version) -> None:
    """fmpy's own build (CMake, its FMI headers) compiles ``sources/`` from the build
    description (FMI 3) or the model description's source list (FMI 2); the rebuilt binary
    runs the model."""
    import os
    import sys

    from fmpy.build import build_platform_binary

    bindir = str(Path(sys.executable).parent)  # the venv's cmake (a dependency of fmpy)
    monkeypatch.setenv("PATH", bindir + os.pathsep + os.environ.get("PATH", ""))
    if shutil.which("cmake") is None:
        pytest.skip("cmake not installed")
    model = DIAGNOSED["diag-creep-offset"]
    fmu = build_fmu(model, tmp_path / "r.fmu", fmi_version=version, inverse=True, dt=DT)
    unzip = tmp_path / "x"
    with zipfile.ZipFile(fmu) as zf:
        zf.extractall(unzip)
    shutil.rmtree(unzip / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(unzip.resolve(), build_dir=tmp_path / "build")
    s = Slave(fmu, unzip)  # the unzipped folder with the rebuilt binary
    s.init()
    u = _quiet(model, turning_points(10, 600)).y
    ref = _quiet(causal_form(model.inverse(), DT).model, u).y
    np.testing.assert_allclose(s.run(u), ref, rtol=0, atol=1e-9 * max(1.0, np.ptp(ref)))
    s.close()


def test_the_name_check_still_refuses_an_illegal_name() -> None:
    """The memoised parser of ``_parse_each_variable_name_once`` (this module's FMUs are
    validated through it) still reports a name that breaks the structured convention, also
    when asked twice, and passes the legal ones."""
    from types import SimpleNamespace

    from fmpy.validation import _validate_variable_names

    names = ["s0_pi.weights[1]", "1bad", "u", "1bad", "a..b", "s0_pi.weights[1]"]
    md = SimpleNamespace(variableNamingConvention="structured", modelVariables=[
        SimpleNamespace(name=n, sourceline=k) for k, n in enumerate(names)])
    problems = _validate_variable_names(md)
    assert [p.split(" (line")[0] for p in problems] == ['"1bad"', '"1bad"', '"a..b"']
