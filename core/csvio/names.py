"""Column headers: names, units (``t [s]``, ``u_V``, ``y/um``) and the role names."""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "INDEX_NAMES",
    "INPUT_NAMES",
    "OUTPUT_NAMES",
    "RUN_NAMES",
    "TIME_NAMES",
    "TIME_SCALE",
    "ColumnInfo",
    "norm_unit",
    "parse_column_name",
]

_UNIT_TOKENS = frozenset(
    """s sec ms us µs ns min h Hz kHz V mV uV µV kV A mA uA µA m mm um µm nm cm in ft mil
    N kN mN uN µN lb lbf kip kips Pa kPa MPa GPa psi bar T mT uT µT G Am Apm Wb W mW
    kW J rad deg g kg degC K C F pF nF uF µF Ohm ohm percent pct rpm""".split()
)
_UNIT_NORMALISE = {
    "us": "µs", "uV": "µV", "uA": "µA", "um": "µm", "uN": "µN", "uT": "µT", "uF": "µF",
    "sec": "s", "Am": "A/m", "Apm": "A/m", "ohm": "Ohm", "percent": "%", "pct": "%", "kips": "kip",
}
TIME_SCALE = {
    "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
    "ms": 1e-3, "msec": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9,
    "min": 60.0, "h": 3600.0,
}
TIME_NAMES = frozenset({"t", "time", "times", "timestamp", "time_stamp", "zeit", "temps"})
RUN_NAMES = frozenset(
    {"run", "run_id", "runid", "record", "recording", "loop", "trial", "experiment", "rep"}
)
INDEX_NAMES = frozenset({"k", "idx", "index", "sample", "samples", "sample_index", "#", "no",
                          "nr"})
INPUT_NAMES = frozenset({"u", "input", "in"})
OUTPUT_NAMES = frozenset({"y", "output", "out"})
_BRACKET = re.compile(r"^(.*?)\s*[\[(\{]\s*([^\])\}]*?)\s*[\])\}]\s*$")
_SLASH = re.compile(r"^(.*?\S)\s*/\s*([^/\s]{1,12})$")


def norm_unit(unit: str) -> str:
    unit = unit.strip()
    unit = _UNIT_NORMALISE.get(unit, unit)
    return unit


def parse_column_name(raw: str) -> tuple[str, str]:
    """Split a column header into ``(name, unit)``.

    Recognised forms: ``"t [s]"``, ``"Force (kN)"``, ``"u/V"`` (any unit), and
    ``"t_s"``, ``"y_um"``, ``"u_disp_in"``, ``"velocity_in_per_s"`` (an underscore suffix
    that is a known unit, so ``"u_disp"`` stays a name). ``um``/``us``/... become
    ``µm``/``µs``/..., ``Am`` becomes ``A/m``.

    Parameters
    ----------
    raw : str
        The header cell.

    Returns
    -------
    name : str
        The name without the unit (stripped; the raw text when nothing matched).
    unit : str
        The unit, ``""`` when none was found.

    Examples
    --------
    >>> parse_column_name("y_um"), parse_column_name("Force (kN)")
    (('y', 'µm'), ('Force', 'kN'))
    """
    s = raw.strip()
    m = _BRACKET.match(s)
    if m and m.group(1):
        return m.group(1).strip(), norm_unit(m.group(2))
    m = _SLASH.match(s)
    if m and "_" not in m.group(2):
        return m.group(1).strip(), norm_unit(m.group(2))
    parts = s.split("_")
    if len(parts) >= 4 and parts[-2] == "per" and parts[-3] in _UNIT_TOKENS \
            and parts[-1] in _UNIT_TOKENS:
        a, b = norm_unit(parts[-3]), norm_unit(parts[-1])
        return "_".join(parts[:-3]), f"{a}/{b}"
    if len(parts) >= 2 and parts[-1] in _UNIT_TOKENS and parts[0]:
        return "_".join(parts[:-1]), norm_unit(parts[-1])
    return s, ""


@dataclass(frozen=True)
class ColumnInfo:
    """One column of a CSV.

    Attributes
    ----------
    index : int
        0-based position.
    raw : str
        The header cell as written (``"column 3"`` without a header).
    name : str
        Name without the unit.
    unit : str
        Unit (``""`` if unknown).
    """

    index: int
    raw: str
    name: str
    unit: str

    @property
    def key(self) -> str:
        """Lower-case name used for matching."""
        return self.name.lower()

    def label(self) -> str:
        """``'u_V' (column 1)`` for messages (``column 1`` without a header)."""
        if self.raw == f"column {self.index}":
            return self.raw
        return f"{self.raw!r} (column {self.index})"
