"""Strings of a parameter set never become code (issue 35 item 1).

The reference is the C compiler itself: every payload carries a marker identifier
(``PWNED...``); after ``gcc -std=c99 -E`` (comments removed, trigraphs and line splices
applied exactly as a compiler sees them) no marker may be left. Units are refused at load
time by the unit grammar, with the field named.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.base import model_class
from core.escape import c_comment, c_string, xml_attr
from core.exceptions import NotInvertibleError
from core.export_c import generate_c
from core.paramset import (
    ParameterSet,
    ParameterSetError,
    Provenance,
    Units,
    clean_unit,
    load_parameter_set,
    unit_problem,
)
from tests.core.model_zoo import DT, EX1, ZOO

GCC = shutil.which("gcc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc not installed")

#: The payloads of the probe: each closes the comment its own way and then declares code
#: named PWNED<i>. Line splices: backslash-newline, backslash-space-newline (GCC accepts
#: it), the trigraph ??/ (a backslash under -std=c99); a constructor that would run at load.
PAYLOADS = [
    "V */ int PWNED0 = 1; /*",
    "*\\\n/ int PWNED1 = 1; /*",
    "*\\ \n/ int PWNED2 = 1; /*",
    "*??/\n/ int PWNED3 = 1; /*",
    '*/ __attribute__((constructor)) static void PWNED4(void) { system("id"); } /*',
    "\u202e */ int PWNED5; /* \u202c",
    "*/\n#define PWNED6 1\n/*",
    "\r*/ int PWNED7;\x00/*",
    "**// int PWNED8; //**",
    "*\\\r\n/ int PWNED9 = 1; /*",
]


def _preprocess(text: str, tmp: Path, *include: Path) -> str:
    src = tmp / "probe.c"
    src.write_text(text, encoding="utf-8")
    inc = [a for d in include for a in ("-I", str(d))]
    proc = subprocess.run([GCC, "-std=c99", "-E", "-P", *inc, str(src)],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[:2000]
    return proc.stdout


def _hostile_provenance(payload: str) -> Provenance:
    return Provenance(created=payload, tool=payload, source=payload, notes=payload,
                      fit={"report": payload, payload: [payload]}, extra={"x": payload})


# ----------------------------------------------------------------------------- units
@pytest.mark.parametrize("payload", PAYLOADS + ["V; int x", "um\\", "{V}", 'V"'])
@pytest.mark.parametrize("key", ["input", "output", "time"])
def test_a_unit_that_is_not_a_unit_is_refused_at_load_with_its_field(key, payload) -> None:
    doc = ParameterSet.from_model(EX1).to_dict()
    doc["units"][key] = payload
    with pytest.raises(ParameterSetError, match=rf"^units\.{key}: .*(cannot hold|at most)"):
        load_parameter_set(json.dumps(doc))
    with pytest.raises(ParameterSetError, match=rf"^units\.{key}: "):
        Units(**{key: payload})


@pytest.mark.parametrize("unit", ["V", "um", "µm", "A/m", "N/mm^2", "m²", "kip", "%", "°C",
                                  "m s^-1", "1/V", "Ω", ""])
def test_real_units_are_accepted(unit) -> None:
    assert unit_problem(unit) is None
    assert Units(input=unit).input == unit
    assert clean_unit(unit) == unit


def test_a_header_unit_that_is_not_a_unit_becomes_unknown() -> None:
    assert clean_unit("V */ int x; /*") == ""
    assert clean_unit("x" * 40) == ""


# ----------------------------------------------------------------------------- C
@needs_gcc
@pytest.mark.parametrize("type_name", sorted(ZOO))
def test_no_string_of_a_parameter_set_survives_preprocessing(type_name, tmp_path) -> None:
    """Every registered type: hostile provenance in every string field, and hostile text in
    every free-form field of the model itself (refused there, or neutralised)."""
    model = ZOO[type_name]
    payload = "\n".join(PAYLOADS)
    cls = model_class(type_name)
    doc = model.to_dict()
    for f in cls.fields:
        if f.kind == "any":  # the only model fields that may hold a string
            hostile = dict(doc, **{f.name: payload})
            with pytest.raises(ValueError):
                ParameterSet.from_dict({"format": "hysteresis-explorer/parameter-set",
                                        "version": 1, "model": hostile})
    ps = ParameterSet(model, Units("V", "um", "s"), _hostile_provenance(payload))
    try:
        code = generate_c(ps, "hx", inverse=True, forward=type_name != "advance", dt=DT)
    except NotInvertibleError:
        code = generate_c(ps, "hx", inverse=False, forward=True, dt=DT)
    assert code.header.isascii() and code.source.isascii()
    code.write(tmp_path)
    out = _preprocess((tmp_path / "hx.c").read_text(), tmp_path, tmp_path)
    assert "_step(" in out  # the code is there, only the payload is gone
    assert "PWNED" not in out
    assert "system" not in out and "constructor" not in out


@needs_gcc
def test_comment_and_string_escapes_hold_for_any_text(tmp_path) -> None:
    """Hypothesis draws texts (control, bidi, backslashes, stars, slashes, question marks);
    each sits in a comment followed by a declaration, and in a string literal printed back:
    the preprocessor must leave exactly the declarations, and the program print the
    literals' ASCII spelling."""
    texts: list[str] = []
    alphabet = st.sampled_from(list("*/?\\\n\r \t\"'abc=;(){}#") + ["\u202e", "\u2066",
                                                                  "\x00", "µ", "\ud800"])

    @settings(max_examples=300, deadline=None, database=None)
    @given(st.text(alphabet, max_size=24))
    def collect(t: str) -> None:
        texts.append(t)

    collect()
    body = "".join(f"/* {c_comment(t)} */ int ok{i};\n" for i, t in enumerate(texts))
    out = _preprocess(body, tmp_path)
    assert out.split() == [w for i in range(len(texts)) for w in ("int", f"ok{i};")]
    prog = "#include <stdio.h>\nint main(void) {\n" + "".join(
        f'    puts({c_string(t)});\n' for t in texts) + "    return 0;\n}\n"
    (tmp_path / "s.c").write_text(prog)
    exe = tmp_path / "s"
    proc = subprocess.run([GCC, "-std=c99", "-Wall", "-Werror", "-o", str(exe),
                           str(tmp_path / "s.c")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[:2000]
    printed = subprocess.run([str(exe)], capture_output=True, check=True).stdout
    expected = "".join(
        "".join(c if " " <= c <= "~" else f"U+{ord(c):04X}" for c in t) + "\n" for t in texts)
    assert printed.decode("ascii") == expected


def test_c_comment_examples() -> None:
    assert c_comment("V */ int x; /*") == "V * / int x; / *"
    assert c_comment("a\\") == "aU+005C"
    assert "??" not in c_comment("???/")
    assert c_comment("\u202e") == "U+202E"


# ----------------------------------------------------------------------------- FMU
@needs_gcc
def test_fmu_sources_and_description_hold_hostile_provenance(tmp_path) -> None:
    pytest.importorskip("fmpy")
    from core.export_fmu import fmi_headers, fmu_sources
    from core.stages import Lag

    payload = "\n".join(PAYLOADS) + ' "/><Evil x="1'
    ps = ParameterSet(EX1 >> Lag(1e-3), Units("V", "µm", "s"), _hostile_provenance(payload))
    for version in (3, 2):
        for inverse in (False, True):
            src = fmu_sources(ps, fmi_version=version, inverse=inverse, dt=DT)
            assert src.source.isascii()
            out = _preprocess(src.source, tmp_path, fmi_headers(version))
            assert "PWNED" not in out
            root = ET.fromstring(src.model_description.encode("utf-8"))
            assert root.find(".//Evil") is None
            assert not any(c in src.model_description for c in "\u202e\u202c\x00")
            assert root.get("description") is not None


def test_xml_attr_round_trips_through_a_parser() -> None:
    text = 'a"b<c>&d\ne\u202ef\x01'
    got = ET.fromstring(f"<x v={xml_attr(text)}/>").get("v")
    assert got == 'a"b<c>&d\ne?f?'


def test_escapes_are_total_on_random_text() -> None:
    rng = np.random.default_rng(5)
    for _ in range(200):
        t = "".join(chr(int(c)) for c in rng.integers(0, 0x3000, size=12) if not
                    0xD800 <= c < 0xE000)
        assert c_comment(t).isascii() and "*/" not in c_comment(t)
        assert c_string(t).isascii()
