"""``TrialConfig``'s plain fields (numbers, names, flags): their defaults and choices.

``trial.TrialConfig`` takes its defaults from :data:`TRIAL_DEFAULTS`, and ``python -m experiments
run`` generates its options from them and from ``bounds.LIMITS``. This module imports nothing
heavy (no MuJoCo, numba or conformal), so ``run --help`` stays fast. Three values have their home
in modules that do import MuJoCo or numba; they are repeated here and a test checks they agree:
``visual_latency_ms`` (``models.VISUAL_LATENCY_MS``), ``threshold`` (``decode.DEFAULT_THRESHOLD``)
and the choices of ``saccade_model`` and ``eye_drive`` (``models.SACCADE_MODELS``, ``models.EYE_DRIVES``).
"""

from __future__ import annotations

from typing import Any

from .mechanisms import CONDITIONS, MODELS, PARADIGMS

__all__ = ["TRIAL_CHOICES", "TRIAL_DEFAULTS"]

#: The default of every plain field of ``TrialConfig`` (not ``timecourse``, ``generator``,
#: ``observer``, ``population``: objects with their own defaults).
TRIAL_DEFAULTS: dict[str, Any] = {
    "image_size": 256,
    "fovy_deg": 90.0,
    "fovea_deg": 2.0,
    "threshold": 0.2,  # decode.DEFAULT_THRESHOLD
    "endpoint_noise": 0.0,
    "oversample": 3,
    "flash_radius_deg": 1.0,
    "saccade_model": "burst",
    "eye_drive": "plant",
    "eye_position": "signal",
    "visual_latency_ms": 70.0,  # models.VISUAL_LATENCY_MS
    "model": "mechanistic",
    "condition": "references",
    "paradigm": "localization",
    "feedback_gain": 4.5,
    "reference_weight": 1.0,
    "reference_unit": 8.4e-3,
    "disabled": (),
    "stability_tolerance": 0.1,
    "report_noise_deg": 0.5,
    "eps_sigma_ms": 50.0,
    "eps_delay_ms": 50.0,
    "reference_contrast": 1.0,
    "reference_ms": 1000,
    "target_off_ms": 1000,
    "markers": (),
    "ruler": True,
}

#: The allowed values of every text field.
TRIAL_CHOICES: dict[str, tuple[str, ...]] = {
    "saccade_model": ("burst", "legacy"),  # models.SACCADE_MODELS
    "eye_drive": ("plant", "servo"),  # models.EYE_DRIVES
    "eye_position": ("signal", "true"),
    "model": MODELS,
    "condition": CONDITIONS,
    "paradigm": PARADIGMS,
}
