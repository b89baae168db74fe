"""A picture uploaded as a recording (issue 33, item 6): the refusal in words a student
understands ("not a CSV text file"), without byte offsets, on the preview and the upload
(viser's upload goes through the same service)."""

from __future__ import annotations

import pytest

from app.services.analysis.recordings import csv_preview, read_upload
from core.csvio import CSVError

PNG = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x06" + b"\x00" * 40


def test_a_png_preview_is_not_a_csv_text_file() -> None:
    with pytest.raises(CSVError) as err:
        csv_preview(PNG, 1000)
    text = str(err.value)
    assert text.startswith("This file is not a CSV text file")
    assert "NUL" not in text and "offset" not in text and "<" not in text


def test_a_png_upload_names_the_file() -> None:
    with pytest.raises(CSVError) as err:
        read_upload(PNG, name="loop.png")
    assert str(err.value).startswith("loop.png is not a CSV text file"), str(err.value)


def test_other_csv_errors_are_unchanged() -> None:
    with pytest.raises(CSVError) as err:
        read_upload("t,u,y\n0,1\n", name="short.csv")
    assert "not a CSV text file" not in str(err.value)
