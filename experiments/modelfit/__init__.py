"""Fitting the perception models to a lab's localization data, comparing them, and simulating data.

``python -m experiments fit`` / ``compare`` / ``simulate`` (command line: ``experiments.cli``),
``recovery`` (``modelfit.recovery``), ``crossval`` (``modelfit.crossval``); the published data
sets and their provenance (``modelfit.published``, ``experiments/data/published/``).
"""

from .crossval import CrossvalFolderError, crossvalidate
from .data import OPTIONAL, REQUIRED, DataConventionWarning, DataFormatError, LocalizationData, read_data
from .fitting import IMAGE_SIZE, FitError, FitFolderError, compare, fit, fit_key, simulate_data
from .forward import ForwardModel, ForwardModelError, forward_model
from .likelihood import FIT_MODELS, NESTED, FitModel, Parameter
from .observe import BACKENDS, observe_trials
from .published import PUBLISHED_DIR
from .published import check as check_published

__all__ = [
    "REQUIRED",
    "OPTIONAL",
    "DataFormatError",
    "DataConventionWarning",
    "LocalizationData",
    "read_data",
    "fit",
    "compare",
    "simulate_data",
    "IMAGE_SIZE",
    "FitError",
    "FitFolderError",
    "fit_key",
    "ForwardModel",
    "ForwardModelError",
    "forward_model",
    "FIT_MODELS",
    "NESTED",
    "FitModel",
    "Parameter",
    "BACKENDS",
    "observe_trials",
    "crossvalidate",
    "CrossvalFolderError",
    "PUBLISHED_DIR",
    "check_published",
]
