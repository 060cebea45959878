"""Turski's conformal camera: geometry, exp-polar retina, DPFT, remapping and cortex.

Pure math on numpy arrays; never imports MuJoCo, so it works on any image. Every public function
checks its arguments (``conformal.checks``): bad input raises a ``ValueError`` or ``TypeError``
naming the argument, and sizes are bounded.
Equation names refer to the ``\\label``s of the paper (J. Turski, *Geometric Analysis of the
Conformal Camera for Intermediate-Level Vision and Perisaccadic Perception*).

``conformal.TorchRemapPlan`` (the DPFT and the remapping series in torch, ``conformal.torch_plan``) is
loaded on first use: ``import conformal`` never imports torch.
"""

from . import checks, kernels
from .cortex import BinocularCortex, binocular_cortex, cortical_map, hemifields, schwartz_map
from .dpft import (
    OffGridEvaluator,
    dpft,
    dpft_direct,
    evaluate,
    evaluate_direct,
    idpft,
    idpft_direct,
    pft_frequencies,
    transform,
    warp,
)
from .fovea import fovea_dft, fovea_idft, fovea_image, fovea_indices
from .geometry import (
    SPHERE_CENTRE,
    act,
    apply_homography,
    check_rotation,
    check_sl2,
    compose,
    euler_rotation,
    h_matrix,
    inverse,
    k_matrix,
    lift_to_sphere,
    mobius_from_points,
    project,
    rotation_from_su2,
    rotation_homography,
    su2_from_rotation,
    transform_image,
)
from .grid import RetinaGrid
from .maps import POLE_TOL
from .remap import (
    MobiusMap,
    ProjectiveMap,
    homography_map,
    mobius_for_rotation,
    mobius_map,
    predict,
    predict_many,
    rotation_matrix,
    target_shift_map,
)
from .remap_plan import RemapPlan, field_moments
from .sampling import Retina, RetinaSamples, pixel_points
from .shift import log_radius_shift
from .threads import blas_threads

__all__ = [
    "BinocularCortex",
    "MobiusMap",
    "POLE_TOL",
    "checks",
    "kernels",
    "OffGridEvaluator",
    "ProjectiveMap",
    "RemapPlan",
    "Retina",
    "RetinaGrid",
    "RetinaSamples",
    "SPHERE_CENTRE",
    "act",
    "apply_homography",
    "binocular_cortex",
    "blas_threads",
    "check_rotation",
    "check_sl2",
    "compose",
    "cortical_map",
    "dpft",
    "dpft_direct",
    "euler_rotation",
    "evaluate",
    "evaluate_direct",
    "field_moments",
    "fovea_dft",
    "fovea_idft",
    "fovea_image",
    "fovea_indices",
    "h_matrix",
    "hemifields",
    "homography_map",
    "idpft",
    "idpft_direct",
    "inverse",
    "k_matrix",
    "lift_to_sphere",
    "log_radius_shift",
    "mobius_for_rotation",
    "mobius_from_points",
    "mobius_map",
    "pft_frequencies",
    "pixel_points",
    "predict",
    "predict_many",
    "project",
    "rotation_from_su2",
    "rotation_homography",
    "rotation_matrix",
    "schwartz_map",
    "su2_from_rotation",
    "target_shift_map",
    "transform",
    "transform_image",
    "warp",
]


def __getattr__(name: str):
    """``TorchRemapPlan`` on first use (PEP 562), so that torch stays optional."""
    if name == "TorchRemapPlan":
        from .torch_plan import TorchRemapPlan

        return TorchRemapPlan
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
