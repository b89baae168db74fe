"""Large files read in blocks (core.csvio.stream) against the whole-text reader.

The second implementation is the reader that reads the whole text (``read_table_whole``, the
reader every file went through before): with the block sizes made small, every file below
goes through the blocks, and the recordings (values, line numbers, notes, names, units) or
the error (its type and message) must be the same as when it is read whole.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

from core.csvio import CSVError, read_csv, read_input
from core.csvio import load as load_mod
from core.csvio import stream as stream_mod
from core.csvio import table as table_mod
from core.csvio.options import CsvOptions

N = 300
T = np.arange(N) * 0.001
U = 3.0 * np.sin(2 * np.pi * 7 * T) + 0.5 * np.sin(2 * np.pi * 31 * T)
Y = 0.8 * U + 0.1 * np.cos(2 * np.pi * 7 * T)


def rows(sep: str = ",", dec: str = ".", cols: tuple[np.ndarray, ...] = (T, U, Y),
         fmts: tuple[str, ...] = ("{:.4f}", "{:.6f}", "{:.6f}")) -> list[str]:
    return [sep.join(f.format(v).replace(".", dec) for f, v in zip(fmts, r, strict=True))
            for r in zip(*cols, strict=True)]


def text(header: str | None, body: list[str], nl: str = "\n", before: str = "") -> str:
    return before + nl.join(([header] if header is not None else []) + body) + nl


def edit(body: list[str], i: int, new: str) -> list[str]:
    out = list(body)
    out[i] = new
    return out


RUN = np.repeat([1, 2, 3], N // 3)
CASES: dict[str, tuple[str, dict]] = {
    "comma": (text("t_s,u_V,y_um", rows()), {}),
    "semicolon decimal comma": (text("t [s];u [V];y [µm]", rows(";", ",")), {}),
    "tab": (text("t\tu\ty", rows("\t")), {}),
    "whitespace": (text("t u y", rows("   ")), {}),
    "crlf": (text("t_s,u_V,y_um", rows(), nl="\r\n"), {}),
    "preamble and unit row": (text("time,input,output\n(s),(V),(um)", rows(),
                                   before="Scope export\nDate: 2026-12-05\n"), {}),
    "units row": (text("t,u,y\n(s),(V),(um)", rows()), {}),
    "comments at the top": (text("t_s,u_V,y_um", rows(), before="# made by a test\n#\n"), {}),
    "excel sep line": (text("sep=;\nt;u;y", rows(";")), {}),
    "no header two columns": (text(None, rows(cols=(U, Y), fmts=("{:.6f}", "{:.6f}"))),
                              {"fs": 1000.0}),
    "time in ms": (text("t_ms,u_V,y_um", rows(fmts=("{:.1f}", "{:.6f}", "{:.6f}"),
                                                 cols=(T * 1e3, U, Y))), {}),
    "extra column": (text("t_s,u_V,y_um,temp_C", rows(cols=(T, U, Y, 20 + T),
                                                       fmts=("{:.4f}",) * 4)), {}),
    "run column": (text("run,t_s,u_V,y_um", rows(cols=(RUN, T, U, Y),
                                                 fmts=("{:d}", "{:.4f}", "{:.6f}", "{:.6f}"))),
                   {}),
    "NaN and empty cells late": (text("t_s,u_V,y_um", edit(edit(rows(), 250, "0.2500,,1.0"),
                                                           270, "0.2700,nan,1.0")), {}),
    "NA token late, nan=error": (text("t_s,u_V,y_um", edit(rows(), 260, "0.2600,NA,1.0")),
                                 {"nan": "error"}),
    "too many NaN": (text("t_s,u_V,y_um", [r if i < 200 else r.rsplit(",", 1)[0] + ","
                                           for i, r in enumerate(rows())]), {}),
    "quoted cells late": (text("t_s,u_V,y_um", edit(rows(), 280, '0.2800,"1.5",1.0')), {}),
    "blank lines at the end": (text("t_s,u_V,y_um", rows()) + "\n\n  \n", {}),
    "blank line inside late": (text("t_s,u_V,y_um", edit(rows(), 250, "")), {}),
    "comment inside late": (text("t_s,u_V,y_um", edit(rows(), 250, "# pause")), {}),
    "delimiters only late": (text("t_s,u_V,y_um", edit(rows(), 250, ",,")), {}),
    "text column": (text("t_s,u_V,y_um,note", [r + ",ok" for r in rows()]), {}),
    "text cell late in the input": (text("t_s,u_V,y_um", edit(rows(), 290, "0.2900,abc,1")),
                                    {}),
    "decimal comma with a point late": (
        text("t;u;y", edit(rows(";", ","), 250, "0,2500;1.5;1,0")), {}),
    "ragged line late": (text("t_s,u_V,y_um", edit(rows(), 270, "0.2700,1.0")), {}),
    "ragged last line": (text("t_s,u_V,y_um", rows()[:-1] + ["0.2990,1.0"]), {}),
    "time going back late": (text("t_s,u_V,y_um", edit(rows(), 260, "0.1000,1.0,1.0")), {}),
    "uneven time late": (text("t_s,u_V,y_um", edit(rows(), 260, "0.2605,1.0,1.0")), {}),
    "uneven time resampled": (text("t_s,u_V,y_um", edit(rows(), 260, "0.2605,1.0,1.0")),
                              {"resample": True}),
    "trailing delimiter": (text("t_s,u_V,y_um,", [r + "," for r in rows()]), {}),
    "long line late": (text("t_s,u_V,y_um", edit(rows(), 270, "1," * 60_000 + "1")), {}),
    "unclosed quote late": (text("t_s,u_V,y_um", edit(rows(), 270, '0.2700,"1.0,1.0')), {}),
    "too many rows": (text("t_s,u_V,y_um", rows()), {"max_rows": 250}),
    "latin-1 header": ("t_s,u_V,y_\xb5m\n".encode("latin-1")
                       + text(None, rows()).encode(), {}),
    "control byte late": (text("t_s,u_V,y_um", rows()).encode().replace(b"0.2700", b"0.27\x01"),
                          {}),
}


def summary(call, path: Path, **kw):
    """What a read gives: every recording's content, or the error's type and message."""
    try:
        recs = call(path, **kw)
    except CSVError as exc:
        return ("error", type(exc).__name__, str(exc), exc.line, exc.column)
    out = []
    for r in recs if isinstance(recs, list) else [recs]:
        d = {k: v for k, v in vars(r).items() if k != "layout"}
        out.append({k: _plain(v) for k, v in d.items()})
    return out


def _plain(v):
    """Arrays (also inside dicts and tuples) as lists, for ``==``."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, Mapping):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, tuple):
        return tuple(_plain(x) for x in v)
    return v


@pytest.fixture
def small_blocks(monkeypatch):
    """Every file of more than 0 bytes is read in blocks: a head of 4 kB, blocks of 700 B."""
    monkeypatch.setattr(stream_mod, "STREAM_FROM_BYTES", 0)
    monkeypatch.setattr(stream_mod, "HEAD_BYTES", 4000)
    monkeypatch.setattr(stream_mod, "BLOCK_BYTES", 700)
    monkeypatch.setattr(stream_mod, "HEAD_ROWS", 40)


def _write(tmp_path: Path, content: str | bytes) -> Path:
    p = tmp_path / "rec.csv"
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_bytes(content.encode("utf-8"))
    return p


@pytest.mark.parametrize("case", list(CASES))
def test_blocks_read_what_the_whole_text_reads(case, tmp_path, monkeypatch):
    content, kw = CASES[case]
    p = _write(tmp_path, content)
    whole = summary(read_csv, p, **kw)
    with monkeypatch.context() as m:
        m.setattr(stream_mod, "STREAM_FROM_BYTES", 0)
        m.setattr(stream_mod, "HEAD_BYTES", 4000)
        m.setattr(stream_mod, "BLOCK_BYTES", 700)
        m.setattr(stream_mod, "HEAD_ROWS", 40)
        blocks = summary(read_csv, p, **kw)
    assert blocks == whole


@pytest.mark.parametrize("case", ["comma", "whitespace", "NaN and empty cells late",
                                  "text cell late in the input", "extra column"])
def test_input_signals_in_blocks_are_the_same(case, tmp_path, monkeypatch):
    content, kw = CASES[case]
    p = _write(tmp_path, content)
    whole = summary(read_input, p, **kw)
    with monkeypatch.context() as m:
        m.setattr(stream_mod, "STREAM_FROM_BYTES", 0)
        m.setattr(stream_mod, "HEAD_BYTES", 4000)
        m.setattr(stream_mod, "BLOCK_BYTES", 700)
        m.setattr(stream_mod, "HEAD_ROWS", 40)
        blocks = summary(read_input, p, **kw)
    assert blocks == whole


@pytest.mark.parametrize("case", ["comma", "semicolon decimal comma", "run column", "crlf",
                                  "NaN and empty cells late", "quoted cells late",
                                  "blank lines at the end", "preamble and unit row"])
def test_numeric_files_are_read_in_blocks(case, tmp_path, small_blocks):
    """The clean and the NA / quoted cases really go through the blocks (no text is kept)."""
    content, kw = CASES[case]
    p = _write(tmp_path, content)
    table, _ = load_mod.read_table(p, CsvOptions(**kw))
    assert isinstance(table, stream_mod.StreamedTable)
    assert len(table.data) == table.matrix().shape[0] == len(table.lines)


def test_a_file_that_cannot_be_read_in_blocks_is_refused_in_words_above_the_whole_limit(
        tmp_path, small_blocks, monkeypatch):
    content, _ = CASES["comment inside late"]
    p = _write(tmp_path, content)
    monkeypatch.setattr(load_mod, "MAX_BYTES", 1000)
    with pytest.raises(CSVError) as err:
        read_csv(p)
    msg = str(err.value)
    assert f"is {p.stat().st_size:,} bytes, more than the 1,000 bytes read whole" in msg
    assert "line 252 is a comment inside the data" in msg
    assert "pass a larger max_bytes= to read it whole" in msg and err.value.line == 252
    # asked for, the whole-text reader reads it
    assert read_csv(p, max_bytes=10**6, uneven="keep")[0].n_samples == N - 1


def test_numbers_that_do_not_fit_in_memory_are_refused_up_front(tmp_path, small_blocks,
                                                               monkeypatch):
    content, _ = CASES["comma"]
    p = _write(tmp_path, content)
    monkeypatch.setattr(stream_mod, "available_memory", lambda: 10_000)
    with pytest.raises(CSVError, match=r"holds about 302 rows of 3 columns; reading it needs "
                       r"about 0 MB of memory \(80 bytes per row\) and 0 MB are available; "
                       "cut the recording"):
        read_csv(p)


def test_a_large_file_has_no_row_limit_but_memory(tmp_path, small_blocks, monkeypatch):
    """The whole-text limits (here 100 rows) do not apply to a file read in blocks."""
    content, _ = CASES["comma"]
    p = _write(tmp_path, content)
    monkeypatch.setattr(table_mod, "MAX_ROWS", 100)
    monkeypatch.setattr(table_mod, "MAX_BYTES", 1000)
    monkeypatch.setattr(load_mod, "MAX_BYTES", 1000)
    (r,) = read_csv(p)
    np.testing.assert_allclose(r.u, U, atol=1e-6)
    assert r.lines.tolist() == list(range(2, N + 2))


@pytest.mark.parametrize("case", ["ragged line late", "ragged last line", "long line late",
                                  "unclosed quote late", "too many rows"])
def test_errors_found_in_a_block_say_what_the_whole_text_reader_says(case, tmp_path,
                                                                     small_blocks):
    """Above the whole-text limit the block's own error is raised: the same words and line."""
    content, kw = CASES[case]
    p = _write(tmp_path, content)
    with pytest.raises(CSVError) as whole:
        table_mod.read_table_whole(p, CsvOptions(**kw))
    with pytest.raises(CSVError) as blocks:
        stream_mod.read_streamed(p, p.stat().st_size, CsvOptions(**kw), 2)
    assert (str(blocks.value), blocks.value.line) == (str(whole.value), whole.value.line)
