"""DPFT (§5.1) against direct sums, the continuous PFT, and analytic band-limited images."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import conformal as C


def small_grid(m_sectors=16, r0=0.05, rb=1.0):
    return C.RetinaGrid.from_field_of_view(rb, r0, m_sectors)


def trig_image(grid, freqs, rng):
    """f with e^u f(u, theta) a trigonometric polynomial of period T in u: the DPFT series
    reproduces it exactly anywhere. Returns f as a function of z."""
    terms = [(m, n, rng.normal() + 1j * rng.normal()) for m, n in freqs]

    def f(z):
        u, th = np.log(np.abs(z)), np.angle(z)
        s = sum(c * np.exp(1j * (2 * np.pi * m * u / grid.T + n * th)) for m, n, c in terms)
        return np.exp(-u) * s.real

    return f


@settings(max_examples=25, deadline=None)
@given(st.sampled_from([8, 12, 16]), st.floats(0.02, 0.2), st.integers(0, 2**32 - 1))
def test_fft_matches_direct_sums(n_sectors, r0, seed):
    g = small_grid(n_sectors, r0)
    f = np.random.default_rng(seed).normal(size=(g.M, g.N))
    F = C.dpft(f, g)
    assert np.allclose(F, C.dpft_direct(f, g), rtol=1e-10, atol=1e-10 * np.abs(F).max())
    assert np.allclose(C.idpft_direct(F, g).real, f, atol=1e-10)
    assert np.abs(C.idpft(F, g) - f).max() < 1e-12


def test_round_trip_on_paper_grid_with_channels():
    g = C.RetinaGrid.from_picture(512, 512, 4, 296)
    f = np.random.default_rng(0).uniform(size=(g.M, g.N, 3))
    assert np.abs(C.idpft(C.dpft(f, g), g) - f).max() < 1e-12


def test_coefficients_approximate_the_continuous_pft():
    # f = 1 on the annulus: f^(s, 0) = 2 pi (rb^{1-is} - r0^{1-is}) / (1 - is)  (eq. sft)
    g = C.RetinaGrid.from_field_of_view(10.0, 0.1, 128)
    F = C.dpft(np.ones((g.M, g.N)), g)
    s, n = C.pft_frequencies(g)
    a, b = g.r0, g.rb
    for m in range(4):
        exact = 2 * np.pi * (b ** (1 - 1j * s[m]) - a ** (1 - 1j * s[m])) / (1 - 1j * s[m])
        assert abs(F[m, 0] - exact) < 0.01 * abs(exact) + 1e-3 * abs(F[0, 0])
    assert np.abs(F[:, 1:]).max() < 1e-9 * abs(F[0, 0])  # no angular dependence


def test_offgrid_series_reproduces_band_limited_image_anywhere():
    g = small_grid(32)
    rng = np.random.default_rng(1)
    f = trig_image(g, [(0, 0), (1, 2), (-3, 5), (2, -7), (4, 0)], rng)
    F = C.dpft(f(g.points), g)
    r = np.exp(rng.uniform(np.log(g.radii[0]), np.log(g.radii[-1]), 200))
    z = r * np.exp(1j * rng.uniform(-np.pi, np.pi, 200))
    # such an image is band-limited for the paper's series (eq. dppcc') itself
    assert np.allclose(C.evaluate_direct(F, g, z, extension="paper"), f(z), atol=1e-9)
    assert np.allclose(C.evaluate(F, g, z, extension="paper"), f(z), atol=1e-7)


def test_mirror_extension_removes_the_ringing_between_rings():
    g = small_grid(32)
    F = C.dpft(np.ones((g.M, g.N)), g)
    half = g.points * np.exp(0.5 * g.delta)  # half a ring off the grid
    paper = C.evaluate(F, g, half, extension="paper")
    assert np.abs(paper - 1).max() > 0.3  # e^u f jumps by e^T at the seam: Gibbs ringing
    assert np.allclose(C.evaluate(F, g, half), 1.0, atol=1e-9)
    # a smooth image is interpolated to second order between rings
    f = lambda z: np.cos(0.3 * np.log(np.abs(z))) + 0.1 * np.sin(np.angle(z))
    Ff = C.dpft(f(g.points), g)
    inner = half[:-1]
    assert np.abs(C.evaluate(Ff, g, inner) - f(inner)).max() < 0.01


def test_nufft_agrees_with_direct_sum_on_64x128():
    g = C.RetinaGrid(r0=0.05, delta=2 * np.pi / 128, M=64, N=128, fovea_spacing=0.01, n_fovea=10)
    rng = np.random.default_rng(2)
    F = C.dpft(rng.normal(size=(g.M, g.N)), g)
    z = g.points * np.exp(0.3 * g.delta + 0.2j)
    for ext in ("mirror", "paper"):
        fast = C.OffGridEvaluator(g, z, method="nufft", extension=ext)(F)
        slow = C.evaluate_direct(F, g, z, extension=ext)
        assert np.abs(fast - slow).max() < 1e-6 * np.abs(slow).max()
    small = C.OffGridEvaluator(g, z[:4, :8], method="matrix")(F)  # real data: DCT / rfft path
    assert np.allclose(small, C.evaluate_direct(F, g, z[:4, :8]), atol=1e-9)
    go = C.RetinaGrid.from_field_of_view(1.0, 0.05, 18)  # odd M or N: no Nyquist terms
    fo = C.dpft(rng.normal(size=(go.M, go.N, 2)), go)
    zo = go.points * np.exp(0.3 * go.delta + 0.2j)
    assert np.allclose(C.OffGridEvaluator(go, zo, method="matrix")(fo), C.evaluate_direct(fo, go, zo), atol=1e-9)


def test_single_precision_tables_agree_with_direct_sum():
    """dtype=float32 (the env's fast path) is the same series to single precision, on even and
    odd grids, for RGB and single-channel data, and is chosen by "auto" for env-sized problems."""
    rng = np.random.default_rng(7)
    for g in (C.RetinaGrid.from_field_of_view(0.7, 0.0524, 36), C.RetinaGrid.from_field_of_view(1.0, 0.05, 18)):
        for shape in ((g.M, g.N, 3), (g.M, g.N)):
            F = C.dpft(rng.uniform(size=shape), g)
            r = np.exp(rng.uniform(g.u[0] - g.delta / 2, g.u[-1] + g.delta / 2, 2000))
            z = r * np.exp(1j * rng.uniform(-np.pi, np.pi, 2000))
            ev = C.OffGridEvaluator(g, z, dtype=np.float32)
            assert ev.method == "matrix"
            got = ev(F)
            assert got.dtype == np.float64 and got.shape == z.shape + shape[2:]
            ref = C.evaluate_direct(F, g, z)
            assert np.abs(got - ref).max() < 2e-5
    with pytest.raises(ValueError, match="float64 or float32"):
        C.OffGridEvaluator(g, z, dtype=np.int32)


def test_rotation_by_one_sector_rolls_and_dilation_shifts_a_ring():
    g = small_grid(16)
    f = np.random.default_rng(3).normal(size=(g.M, g.N))
    F = C.dpft(f, g)
    alpha = 2 * np.pi / g.N
    rot = C.k_matrix(-alpha / 2, 0.0, -alpha / 2)  # g . z = e^{i alpha} z
    assert np.allclose(C.act(rot, np.array([1.0 + 0j])), np.exp(1j * alpha))
    assert np.allclose(C.transform(F, g, rot), np.roll(f, 1, axis=1), atol=1e-7)
    dil = C.h_matrix(0.0, math.exp(-g.delta) - 1, 0.0)  # g . z = e^{delta} z
    assert np.allclose(C.act(dil, np.array([1.0 + 0j])), np.exp(g.delta))
    out = C.transform(F, g, dil)
    assert np.allclose(out[1:], f[:-1], atol=1e-7)


def test_transform_by_translation_matches_analytic_image():
    g = small_grid(32)
    f = trig_image(g, [(0, 0), (1, 1), (0, 3)], np.random.default_rng(4))
    F = C.dpft(f(g.points), g)
    h = C.h_matrix(0.02, 0.1, -0.03)
    target = C.act(C.inverse(h), g.points)
    inside = (np.abs(target) > g.radii[0]) & (np.abs(target) < g.radii[-1])
    assert np.allclose(C.transform(F, g, h, extension="paper")[inside], f(target[inside]), atol=1e-7)
    warped = C.warp(F, g, lambda z: C.act(C.inverse(h), z), extension="paper")
    assert np.allclose(warped[inside], f(target[inside]), atol=1e-7)


def test_warp_by_an_eye_rotation_homography_matches_analytic_image():
    """Any point map, not only a Moebius one: the rotation homography of a pinhole eye.
    The image is a cosine series in u about the annulus edges (what the default mirror
    extension represents exactly) times angular harmonics, so f(w(z)) is known in closed form."""
    g = small_grid(32, r0=0.05, rb=1.0)
    rng = np.random.default_rng(11)
    terms = [(m, n, rng.normal(), rng.uniform(0, 2 * np.pi)) for m, n in ((0, 0), (1, 1), (3, 2), (2, 5))]
    u_edge = g.u[0] - g.delta / 2

    def f(z):
        u, th = np.log(np.abs(z)), np.angle(z)
        return sum(c * np.cos(np.pi * m * (u - u_edge) / g.T) * np.cos(n * th + ph) for m, n, c, ph in terms)

    F = C.dpft(f(g.points), g)
    R = C.rotation_matrix([0.3, 0.1, 1.0], np.radians(7))
    w = C.homography_map(R)(g.points)
    inside = (np.abs(w) > g.radii[0]) & (np.abs(w) < g.radii[-1])
    assert inside.sum() > 0.5 * inside.size
    assert np.allclose(C.warp(F, g, C.homography_map(R))[inside], f(w[inside]), atol=1e-9)
    single = C.OffGridEvaluator(g, w[inside], dtype=np.float32)(F)
    assert np.allclose(single, f(w[inside]), atol=1e-4)


def test_log_radius_shift_integer_and_wrap():
    g = small_grid(16)
    f = np.random.default_rng(5).normal(size=(g.M, g.N, 2))
    w = C.log_radius_shift(f, g, 2, wrap=True)
    assert np.allclose(w[:-2], f[2:], atol=1e-12)  # f(u_k + 2 delta) = f_{k+2}
    assert np.allclose(w[-2:], f[:2] * np.exp(-g.T), atol=1e-12)  # re-enters from the periphery
    nw = C.log_radius_shift(f, g, 2)
    assert np.allclose(nw[:-2], f[2:], atol=1e-12) and np.allclose(nw[-2:], 0, atol=1e-12)
    back = C.log_radius_shift(f, g, -1)
    assert np.allclose(back[1:], f[:-1], atol=1e-12) and np.allclose(back[0], 0, atol=1e-12)


def test_fractional_shift_is_the_analytic_dilation():
    g = C.RetinaGrid(r0=0.05, delta=0.2, M=15, N=16, fovea_spacing=0.01, n_fovea=10)  # odd M
    f = trig_image(g, [(0, 0), (2, 1), (-1, 3)], np.random.default_rng(6))
    out = C.log_radius_shift(f(g.points), g, 0.37, wrap=True)
    # within the annulus, away from the wrap seam, it is f(e^{0.37 delta} z)
    assert np.allclose(out[:-1], f(g.points * np.exp(0.37 * g.delta))[:-1], atol=1e-9)
    # the default (mirror, no wrap) shift of a smooth image is accurate and does not ring
    s = lambda z: 0.5 + 0.3 * np.cos(0.4 * np.log(np.abs(z)) + np.angle(z))
    sh = C.log_radius_shift(s(g.points), g, 0.37)
    assert np.abs(sh[:-1] - s(g.points * np.exp(0.37 * g.delta))[:-1]).max() < 0.01
    far = C.log_radius_shift(s(g.points), g, 1.6)
    assert np.all(far[-2:] == 0) and np.all(far[:-2] != 0)  # sources beyond the annulus are unknown


@pytest.mark.parametrize(
    "call",
    [
        lambda g: C.dpft(np.zeros((3, 3)), g),
        lambda g: C.dpft(np.full((g.M, g.N), np.nan), g),
        lambda g: C.idpft(np.zeros((g.M + 1, g.N)), g),
        lambda g: C.evaluate(np.zeros((g.M, g.N)), g, np.array([0j])),
        lambda g: C.evaluate(np.zeros((g.M, g.N)), g, np.array([np.inf + 0j])),
        lambda g: C.log_radius_shift(np.zeros((g.M, g.N)), g, np.nan),
        lambda g: C.dpft(np.zeros((g.M, g.N)), "grid"),
    ],
)
def test_bad_input_raises(call):
    with pytest.raises(ValueError):
        call(small_grid(16))
