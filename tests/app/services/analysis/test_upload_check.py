"""The upload checks' words (app/services/analysis/upload_check.py): sizes written as the web
page writes them (JavaScript's toFixed rounds a half up; kB rounded up), a size reading the
same as the limit written finer, the first bytes named. The words are compared with the web
page's own, for the same files, in tests/e2e/test_viser_upload_check.py."""

from __future__ import annotations

from app.services.analysis.upload_check import not_text, size_text, too_large


def test_sizes_are_written_as_the_web_page_writes_them() -> None:
    # (1.25).toFixed(1) is "1.3" in JavaScript (1.25 is exact: the half goes up)
    assert size_text(1_250_000) == "1.3 MB"
    assert size_text(51_459_986) == "51.5 MB"
    assert size_text(999) == "1 kB" and size_text(1001) == "2 kB" and size_text(0) == "0 kB"


def test_a_file_over_the_limit_is_refused_in_words() -> None:
    assert too_large("a.csv", 5_000_000, 5_000_000) is None
    msg = too_large("long-run.csv", 5_027_000, 5_000_000)
    assert msg is not None
    assert msg.startswith("long-run.csv is 5.03 MB, more than the 5.0 MB this explorer takes.")
    assert "bytes" not in msg
    assert str(too_large("b.csv", 51_459_986, 5_000_000)).startswith("b.csv is 51.5 MB,")
    assert str(too_large("c.csv", 1000, 999)).startswith("c.csv is 1,000 bytes, more than the 1 kB")


def test_first_bytes_that_are_not_csv_text_are_named() -> None:
    assert "looks like a PNG image" in str(not_text("loop.png", b"\x89PNG\r\n\x1a\n\x00"))
    assert "an Excel .xlsx workbook" in str(not_text("m.xlsx", b"PK\x03\x04rest"))
    assert "a binary file, not text" in str(not_text("m.bin", b"t,u,y\n\x00\x01"))
    # UTF-16 text holds NUL bytes and is text; a NUL past the first 4096 bytes is not seen
    assert not_text("u16.csv", "t,u,y\n".encode("utf-16")) is None
    assert not_text("late.csv", b"t,u,y\n" + b"0,1,2\n" * 700 + b"\x00") is None
    assert not_text("plain.csv", b"t,u,y\n0,1,2\n") is None
