"""Hysteresis Explorer numerical core: PI-family models, exact inverses, fitting, diagnosis.

Import-light on purpose: no web or plotting libraries are imported here.
"""

from __future__ import annotations

from . import models  # noqa: F401  (imports and registers every model type)
from .base import Chain, Model, Response, model_from_dict, register_model, registered_types
from .closed_loop import ClosedLoopResult, HammersteinLoop, paper001_loop, simulate_fig16
from .csvio import (
    CSVError,
    InputSignal,
    inspect_csv,
    read_csv,
    read_csvs,
    read_input,
    read_recording,
)
from .datasets import dataset_info, list_datasets, load_dataset
from .deadzone import DeadZoneMap
from .diagnosis import DiagnosisResult, diagnose
from .digitized import DigitizedPI, DigitizedState, DigitizedTrace, StateGraph
from .digitized_deadzone import DigitizedDeadZone, DigitizedModifiedPI
from .exceptions import (
    ClippedInputWarning,
    FitWarning,
    HysteresisError,
    NotFittedError,
    NotInvertibleError,
    ParameterError,
)
from .export_c import CExportError, export_c, generate_c
from .export_fmu import FmuExportError, build_fmu
from .export_mat import export_mat, read_mat
from .fitting import (
    DeadZoneGPIRegressor,
    DigitizedPIRegressor,
    FitReport,
    ModifiedPIRegressor,
    PIRegressor,
    PreisachRegressor,
    TanhGPIRegressor,
)
from .gpi import (
    DeadZoneGPI,
    ModifiedPI,
    TanhEnvelope,
    TanhEnvelopeInverse,
    TanhGPI,
    paper001_example4,
    paper001_example6,
)
from .lti import InverseLinearSystem, LinearSystem
from .operators import dead_zone, play, play_bank, stop
from .paramset import ParameterSet, ParameterSetError, Provenance, Units, load_parameter_set
from .pi import PIModel, inverse_parameters
from .preisach import PreisachInverse, PreisachModel
from .presets import PresetInfo, get_preset, list_presets
from .recordings import Recording
from .signals import SIGNALS, build_signal, list_signals
from .stages import (
    Advance,
    Asymmetry,
    AsymmetryInverse,
    Creep,
    CreepInverse,
    Delay,
    Drift,
    InitialMemory,
    Lag,
    LagInverse,
    Offset,
    RateDependentPI,
    RateDependentPIInverse,
    Resonance,
    ResonanceInverse,
    causal_form,
)

__all__ = [
    "Advance",
    "AsymmetryInverse",
    "CreepInverse",
    "LagInverse",
    "RateDependentPIInverse",
    "ResonanceInverse",
    "causal_form",
    "Asymmetry",
    "Creep",
    "Delay",
    "DiagnosisResult",
    "Drift",
    "InitialMemory",
    "Lag",
    "Offset",
    "RateDependentPI",
    "Resonance",
    "diagnose",
    "SIGNALS",
    "ClosedLoopResult",
    "HammersteinLoop",
    "InverseLinearSystem",
    "LinearSystem",
    "PresetInfo",
    "build_signal",
    "get_preset",
    "list_presets",
    "list_signals",
    "paper001_loop",
    "simulate_fig16",
    "CSVError",
    "InputSignal",
    "Recording",
    "dataset_info",
    "inspect_csv",
    "list_datasets",
    "load_dataset",
    "read_csv",
    "read_csvs",
    "read_input",
    "read_recording",
    "CExportError",
    "FmuExportError",
    "ParameterSet",
    "ParameterSetError",
    "Provenance",
    "Units",
    "build_fmu",
    "export_c",
    "export_mat",
    "generate_c",
    "load_parameter_set",
    "read_mat",
    "Chain",
    "DeadZoneGPI",
    "DeadZoneGPIRegressor",
    "DeadZoneMap",
    "DigitizedPIRegressor",
    "FitReport",
    "ModifiedPIRegressor",
    "PIRegressor",
    "TanhGPIRegressor",
    "DigitizedDeadZone",
    "DigitizedModifiedPI",
    "DigitizedPI",
    "DigitizedState",
    "DigitizedTrace",
    "ModifiedPI",
    "StateGraph",
    "TanhEnvelope",
    "TanhEnvelopeInverse",
    "TanhGPI",
    "paper001_example4",
    "paper001_example6",
    "ClippedInputWarning",
    "FitWarning",
    "HysteresisError",
    "Model",
    "NotFittedError",
    "NotInvertibleError",
    "PIModel",
    "ParameterError",
    "PreisachInverse",
    "PreisachModel",
    "PreisachRegressor",
    "Response",
    "dead_zone",
    "inverse_parameters",
    "model_from_dict",
    "play",
    "play_bank",
    "register_model",
    "registered_types",
    "stop",
]
