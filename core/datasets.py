"""The real measured recordings shipped in ``examples/data``, loadable by name.

Every dataset is a measurement from a public repository, shipped with its licence file and an
``ATTRIBUTION.md`` in its folder. :func:`load_dataset` returns
:class:`~core.recordings.Recording` objects with units and the attribution filled in
(``Recording.citation``), e.g.::

    >>> from core.datasets import load_dataset
    >>> rec = load_dataset("piezo-150V-1Hz")           # doctest: +SKIP
    >>> rec.fs, rec.units["input"], rec.units["output"]  # doctest: +SKIP
    (5000.0, 'V', 'µm')

========================  ==========================================  ==========  ===========
name                      what                                         u → y       returns
========================  ==========================================  ==========  ===========
piezo-150V-1Hz            piezo actuator, ±150 V 1 Hz sine, 5 kHz      V → µm      Recording
friction-0.25Hz-30lb      rotary friction damper, tapered sine,        in → kip    Recording
friction-1Hz-30lb         1024 Hz (frequency, band tension in name)
friction-1Hz-36lb
friction-2Hz-30lb
bh-MnZn-ferrite           B(H) loops, one per amplitude,               A/m → T     list (loops)
bh-MnZn-HP-ferrite        quasi-static, no time axis
bh-M130-27s-GO-steel
bh-amorphous-alloy
========================  ==========================================  ==========  ===========
"""

from __future__ import annotations

import difflib
import functools
import os
from dataclasses import dataclass, field
from pathlib import Path

from .csvio import CsvOptions, read_csv
from .exceptions import ParameterError
from .recordings import Recording

__all__ = [
    "DATA_DIR",
    "DatasetError",
    "DatasetInfo",
    "dataset_info",
    "list_datasets",
    "load_dataset",
]

#: Folder of the shipped recordings (``<project>/examples/data``).
DATA_DIR = Path(__file__).resolve().parents[1] / "examples" / "data"


class DatasetError(ParameterError):
    """Unknown dataset name, or the shipped data files are missing."""


_PIEZO = (
    "Chandra et al., 'Discovery of sparse hysteresis models for piezoelectric materials', "
    "Appl. Phys. Lett. 2023, doi:10.1063/5.0146134; data: GitHub chandratue/SmartHysteresis, "
    "Data/hysteresis_v_150_1hz.csv (commit e7672dabcabbc75341e9ea965d073f68b27e5cda). "
    "Licence: MIT, copyright (c) 2023 chandratue (examples/data/piezo/LICENSE)."
)
_FRICTION = (
    "Coble, Huggins, Cao, Ricles, Downey, 'Dataset-Friction-Damper-with-Backlash', 2022; "
    "GitHub ARTS-Laboratory/Dataset-Friction-Damper-with-Backlash, data/dataset-2/"
    "characterization datasets (commit 0e09aa9d950760277e31c08cd93fd01f39a5af09), converted "
    "from JSON to CSV. Licence: CC BY-SA 4.0 (examples/data/friction_damper/LICENSE.txt)."
)
_BH = (
    "Roman Szewczyk, JAmodel, GitHub romanszewczyk/JAmodel "
    "(commit 4bbe905d420ce27c66ee93d8b25ef44b553f9175), MATLAB files converted to CSV. "
    "Licence: MIT, copyright (c) 2016 Roman Szewczyk (examples/data/bh_loops/LICENSE)."
)
_SIGNAL = CsvOptions(time="t", input="u", output="y", run=False)
_FRICTION_COLS = CsvOptions(time="t", input="u_disp", output="y_force", run=False)
_BH_COLS = CsvOptions(time=False, input="u_H", output="y_B", run="loop")


@dataclass(frozen=True)
class DatasetInfo:
    """Description of one shipped recording.

    Attributes
    ----------
    name : str
        Name for :func:`load_dataset`.
    folder, file : str
        Location below :data:`DATA_DIR`.
    description : str
        What was measured.
    citation : str
        Source and licence (also stored in every loaded ``Recording.citation``).
    licence : str
        SPDX-like licence name (``"MIT"``, ``"CC-BY-SA-4.0"``).
    licence_file : str
        Licence file name in the folder.
    units : tuple of str
        ``(input unit, output unit)``.
    per_loop : bool
        Whether the file splits into one recording per loop (returns a list).
    read_options : CsvOptions
        Column choices passed to :func:`core.csvio.read_csv`.
    """

    name: str
    folder: str
    file: str
    description: str
    citation: str
    licence: str
    licence_file: str
    units: tuple[str, str]
    per_loop: bool = False
    read_options: CsvOptions = field(default_factory=CsvOptions)

    def path(self, data_dir: str | os.PathLike[str] | None = None) -> Path:
        """Path of the CSV file (under ``data_dir``, :data:`DATA_DIR` by default)."""
        return Path(data_dir or DATA_DIR) / self.folder / self.file


def _friction(freq: str, lb: str) -> DatasetInfo:
    return DatasetInfo(
        name=f"friction-{freq}-{lb}", folder="friction_damper",
        file=f"{freq}{lb}tension0.5amplitude.csv",
        description=(
            f"banded rotary friction damper, {freq} amplitude-tapered sine (7 cycles, nested "
            f"reversals), {lb[:-2]} lb band tension, 0.5 in amplitude, 1024 Hz; displacement "
            "(in) to force (kip); extra channels velocity (in/s), act_force1/2 (lb)"
        ),
        citation=_FRICTION, licence="CC-BY-SA-4.0", licence_file="LICENSE.txt",
        units=("in", "kip"), read_options=_FRICTION_COLS,
    )


def _bh(name: str, file: str, material: str) -> DatasetInfo:
    return DatasetInfo(
        name=name, folder="bh_loops", file=file,
        description=(
            f"{material}: quasi-static symmetric B(H) loops, one per amplitude, no time axis; "
            "field H (A/m) to flux density B (T); extra channels k (sample index), Hpk (A/m)"
        ),
        citation=_BH, licence="MIT", licence_file="LICENSE", units=("A/m", "T"),
        per_loop=True, read_options=_BH_COLS,
    )


_DATASETS: dict[str, DatasetInfo] = {
    d.name: d
    for d in (
        DatasetInfo(
            name="piezo-150V-1Hz", folder="piezo", file="piezo_150V_1Hz.csv",
            description=(
                "piezoelectric actuator: 0 V rest, jump to about -87 V, then a ±150 V 1 Hz "
                "sine; commanded voltage (V) to measured displacement (µm), 5 kHz, 10 s"
            ),
            citation=_PIEZO, licence="MIT", licence_file="LICENSE", units=("V", "µm"),
            read_options=_SIGNAL,
        ),
        _friction("0.25Hz", "30lb"),
        _friction("1Hz", "30lb"),
        _friction("1Hz", "36lb"),
        _friction("2Hz", "30lb"),
        _bh("bh-MnZn-ferrite", "MnZn_ferrite.csv", "MnZn ferrite"),
        _bh("bh-MnZn-HP-ferrite", "MnZn_HP_ferrite.csv", "MnZn high-permeability ferrite"),
        _bh("bh-M130-27s-GO-steel", "M130-27s_GO_steel.csv",
            "M130-27s grain-oriented electrical steel"),
        _bh("bh-amorphous-alloy", "amorphous_alloy.csv", "amorphous alloy"),
    )
}


def list_datasets() -> list[str]:
    """Names of the shipped recordings, in a stable order (piezo, friction, B-H).

    Returns
    -------
    list of str
    """
    return list(_DATASETS)


def dataset_info(name: str) -> DatasetInfo:
    """Description, citation and licence of a shipped recording.

    Raises
    ------
    DatasetError
        For an unknown name (the message lists the known ones and the closest match).
    """
    try:
        return _DATASETS[name]
    except (KeyError, TypeError):
        close = difflib.get_close_matches(str(name), list(_DATASETS), n=1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise DatasetError(
            f"unknown dataset {name!r}; {hint}known datasets: {', '.join(_DATASETS)}"
        ) from None


@functools.lru_cache(maxsize=16)
def _load(name: str, data_dir: str) -> tuple[Recording, ...]:
    info = dataset_info(name)
    path = info.path(data_dir)
    if not path.is_file():
        folder = path.parent
        raise DatasetError(
            f"dataset {name!r}: file {path} is missing"
            + ("" if folder.is_dir() else f" (folder {folder} does not exist)")
            + "; the recordings ship in the project's examples/data folder: use a full "
            "checkout of the project, or pass data_dir= pointing to a copy of that folder"
        )
    lic = path.parent / info.licence_file
    if not lic.is_file():
        raise DatasetError(
            f"dataset {name!r}: licence file {lic} is missing; the data may only be "
            "redistributed with its licence, restore examples/data from the project"
        )
    recs = read_csv(path, info.read_options, name=name, citation=info.citation)
    return tuple(recs)


def load_dataset(
    name: str, *, data_dir: str | os.PathLike[str] | None = None
) -> Recording | list[Recording]:
    """Load a shipped real recording by name (see :func:`list_datasets`).

    Parameters
    ----------
    name : str
        E.g. ``"piezo-150V-1Hz"``, ``"friction-1Hz-30lb"``, ``"bh-MnZn-ferrite"``.
    data_dir : path-like, optional
        Folder holding the ``piezo/``, ``friction_damper/`` and ``bh_loops/`` folders;
        :data:`DATA_DIR` by default.

    Returns
    -------
    Recording or list of Recording
        One recording for the piezo and friction datasets; for the B-H datasets a list with
        one recording per loop (``run`` = loop number, ``has_time=False``). Units come from
        the column names; ``citation`` holds source and licence; ``source`` the file path.
        Results are cached (recordings are immutable).

    Raises
    ------
    DatasetError
        Unknown name, or missing data / licence file (the message says where it looked).
    """
    info = dataset_info(name)
    recs = _load(info.name, str(Path(data_dir or DATA_DIR).resolve()))
    return list(recs) if info.per_loop else recs[0]
