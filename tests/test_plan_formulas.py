"""``models._plan_kernels``' shared scalar formulas as called from numpy code: compiled loops over
broadcast float64 arrays that give what numpy ufuncs of the same formulas give (``numba.vectorize``,
built here as the reference): values, shapes and 0-d results, and x / 0 as inf or NaN, not an error."""

import numba
import numpy as np
import pytest

from models import _plan_kernels as K
from models.eye_kinematics import MainSequence

FORMULAS = [
    (K.listing_torsion, K._listing_torsion, 2),
    (K.vergence_fraction, K._vergence_fraction, 5),
    (K.vergence_rate, K._vergence_rate, 5),
    (K.legacy_position, K._legacy_position, 4),
    (K.legacy_rate, K._legacy_rate, 4),
]


@pytest.mark.parametrize("loop, scalar, n", FORMULAS, ids=[f[0].__name__ for f in FORMULAS])
def test_the_loops_give_what_a_ufunc_gives(loop, scalar, n):
    ufunc = numba.vectorize(scalar)
    rng = np.random.default_rng(n)
    args = [rng.uniform(0.1, 60.0, (4, 3)) for _ in range(n)]
    args[0] = rng.uniform(-20.0, 120.0, (4, 3))
    args[1] = rng.uniform(-1.0, 1.0, (3,))[::-1]  # broadcast, and not contiguous
    with np.errstate(all="ignore"):
        want = ufunc(*args)
        got = loop(*args)
    assert got.shape == want.shape and got.dtype == np.float64
    np.testing.assert_array_equal(got, want)
    scalar_args = [float(a.flat[0]) for a in args]
    with np.errstate(all="ignore"):
        assert loop(*scalar_args) == ufunc(*scalar_args) and np.ndim(loop(*scalar_args)) == 0
    assert loop(*(np.zeros((0,)) for _ in range(n))).shape == (0,)


def test_a_zero_divisor_gives_a_number_as_the_ufunc_did():
    # the legacy main sequence's rate at a subnormal amplitude: 0 deg/ms (a ufunc's x / 0 -> inf), not an error
    np.testing.assert_array_equal(MainSequence().velocity_deg_per_ms([0.5, 1.0], 5e-324), [0.0, 0.0])
