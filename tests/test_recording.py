"""Tests for experiments.recording: write recordings, read them back with Rerun's own reader."""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

import conformal as C
from experiments.__main__ import main
from experiments.recording import Recorder, grid_strips, record_env_run

IMAGE_SIZE = 96
FOVY_DEG = 70.0  # the env's default field of view


def read(path) -> dict[str, dict]:
    """entity -> {"times_ms": sorted array (NaN-free; static chunks excluded), "static": bool,
    "cols": {column: list of values in time order}}."""
    out: dict[str, dict] = defaultdict(lambda: {"times": [], "static": False, "cols": defaultdict(list)})
    for chunk in RrdReader(path).store().stream().to_chunks():
        b = chunk.to_record_batch()
        e = out[chunk.entity_path]
        e["static"] |= chunk.is_static
        if "sim_time" in b.schema.names:
            e["times"].extend((b.column("sim_time").cast(pa.int64()).to_numpy() / 1e6).tolist())
        for name in b.schema.names:
            if ":" in name:
                e["cols"][name].extend(b.column(name).to_pylist())
    for e in out.values():
        order = np.argsort(e["times"], kind="stable")
        e["times_ms"] = np.asarray(e["times"])[order]
        if len(order):
            e["cols"] = {k: [v[i] for i in order] if len(v) == len(order) else v for k, v in e["cols"].items()}
    return dict(out)


def image(entity: dict, i: int = -1) -> np.ndarray:
    fmt = entity["cols"]["Image:format"][i][0]
    buf = np.asarray(entity["cols"]["Image:buffer"][i][0], np.uint8)
    dtype = np.float32 if fmt["channel_datatype"] == 34 else np.uint8
    chans = {1: 1, 2: 3, 3: 4}[fmt["color_model"]]
    return buf.view(dtype).reshape(fmt["height"], fmt["width"], chans).squeeze(-1) if chans == 1 else \
        buf.view(dtype).reshape(fmt["height"], fmt["width"], chans)


def scalars(entity: dict) -> np.ndarray:
    return np.array([v[0] for v in entity["cols"]["Scalars:scalars"]])


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "run.rrd"
    summary = record_env_run(path, steps=2, seed=3, image_size=IMAGE_SIZE, fixation_ms=120)
    return read(path), summary


@pytest.fixture(scope="module")
def grid():
    import envs

    ppu = 0.5 * IMAGE_SIZE / math.tan(math.radians(FOVY_DEG) / 2)
    return envs.Vision((IMAGE_SIZE, IMAGE_SIZE), ppu).grid, ppu


EXPECTED = (
    ["world/head/origin", "world/head/axes", "world/objects", "world/flashes", "flash/true", "flash/perceived",
     "flash/shift", "cortex/left_hemisphere", "cortex/right_hemisphere",
     "saccades/amplitude_deg", "saccades/peak_velocity_deg_s", "saccades/duration_ms"]
    + [f"remap/error/{m}" for m in ("homography", "mobius", "shift")]
    + [p.format(e=e) for e in ("left", "right") for p in (
        "world/eyes/{e}/position", "world/eyes/{e}/gaze", "eyes/{e}/image", "eyes/{e}/grid", "eyes/{e}/target",
        "retina/{e}/fovea", "retina/{e}/logpolar", "dpft/{e}/log_magnitude",
        "remap/{e}/predicted", "remap/{e}/actual", "remap/{e}/difference")]
    + [f"eyes/{e}/{k}/{a}" for e in ("left", "right") for k in ("angle", "velocity") for a in "hvt"]
)


def test_every_entity_present(run):
    data, _ = run
    missing = [p for p in EXPECTED if "/" + p not in data]
    assert not missing, missing


def test_image_shapes(run, grid):
    data, _ = run
    g, _ = grid
    _, _, p = C.fovea_indices(g)
    for e in ("left", "right"):
        assert image(data[f"/eyes/{e}/image"]).shape == (IMAGE_SIZE, IMAGE_SIZE, 3)
        assert image(data[f"/retina/{e}/logpolar"]).shape == (g.M, g.N, 3)
        assert image(data[f"/retina/{e}/fovea"]).shape == (p, p, 3)
        assert image(data[f"/dpft/{e}/log_magnitude"]).shape == (g.M, g.N)
        for kind in ("predicted", "actual", "difference"):
            assert image(data[f"/remap/{e}/{kind}"]).shape == (g.N // 2, 2 * g.M, 3)
    for h in ("left", "right"):
        assert image(data[f"/cortex/{h}_hemisphere"]).shape == (g.N // 2, 2 * g.M, 3)


def test_time_range_and_resolution(run):
    data, summary = run
    start, end = summary["start_ms"], summary["end_ms"]
    assert end - start >= 2 * 120
    for e in ("left", "right"):
        for k in ("angle", "velocity"):
            t = data[f"/eyes/{e}/{k}/h"]["times_ms"]
            assert t[0] <= start + 1 and t[-1] == pytest.approx(end)
            assert np.max(np.diff(t)) <= 1.0 + 1e-9  # every ms at least, over the whole run
    # images at reset, at each flash and after each fixation: 1 + 2 * steps instants, inside the run
    t = data["/eyes/left/image"]["times_ms"]
    assert len(t) == 5 and t[0] == pytest.approx(start) and t[-1] == pytest.approx(end)
    assert len(data["/remap/left/predicted"]["times_ms"]) == 2
    assert data["/eyes/left/grid"]["static"]


def test_every_timed_entity_lies_in_the_run_and_3d_shapes(run):
    """Every non-static entity is logged inside [start, end] of simulated time; the 3-D scene has
    the head, both eyes 6.4 cm apart with unit gaze rays starting at them, and scene objects."""
    data, summary = run
    start, end = summary["start_ms"], summary["end_ms"]
    for p in EXPECTED:
        e = data["/" + p]
        if not e["static"]:
            assert len(e["times_ms"]) and start - 1e-9 <= e["times_ms"][0] and e["times_ms"][-1] <= end + 1e-9, p
    for p in ("cortex/left_hemisphere", "dpft/left/log_magnitude", "retina/right/logpolar"):
        t = data["/" + p]["times_ms"]
        assert t[0] == pytest.approx(start) and t[-1] == pytest.approx(end), p  # reset and last fixation
    assert len(data["/remap/right/actual"]["times_ms"]) == 2  # one per saccade
    assert np.shape(data["/world/head/origin"]["cols"]["Points3D:positions"][-1]) == (1, 3)
    assert np.shape(data["/world/head/axes"]["cols"]["Arrows3D:vectors"][-1]) == (3, 3)
    assert np.shape(data["/world/objects"]["cols"]["Points3D:positions"][-1])[1:] == (3,)
    eyes = {}
    for e in ("left", "right"):
        pos = np.asarray(data[f"/world/eyes/{e}/position"]["cols"]["Points3D:positions"][-1])
        ray = data[f"/world/eyes/{e}/gaze"]["cols"]
        origin, vec = np.asarray(ray["Arrows3D:origins"][-1]), np.asarray(ray["Arrows3D:vectors"][-1])
        assert pos.shape == origin.shape == vec.shape == (1, 3)
        assert origin == pytest.approx(pos, abs=1e-6)
        eyes[e] = pos[0]
    # camera (nodal point) positions: 6.4 cm apart up to the 6 mm nodal offsets' vergence turn
    assert np.linalg.norm(eyes["left"] - eyes["right"]) == pytest.approx(0.064, abs=0.006)


def test_saccades_visible_in_velocity(run):
    data, summary = run
    onsets = data["/saccades/amplitude_deg"]["times_ms"]
    assert len(onsets) == 2
    amp = scalars(data["/saccades/amplitude_deg"])
    peak = scalars(data["/saccades/peak_velocity_deg_s"])
    assert amp == pytest.approx([s["amplitude_deg"] for s in summary["saccades"]])
    t = data["/eyes/left/velocity/h"]["times_ms"]
    speed = np.hypot(scalars(data["/eyes/left/velocity/h"]), scalars(data["/eyes/left/velocity/v"]))
    ang_h = scalars(data["/eyes/left/angle/h"])
    ang_v = scalars(data["/eyes/left/angle/v"])
    for t0, a, pk, s in zip(onsets, amp, peak, summary["saccades"]):
        inside = (t >= t0) & (t <= t0 + s["duration_ms"])
        before = (t < t0) & (t > t0 - 30)
        # the eye moves fast only during the saccade, at about the planned peak velocity
        assert speed[inside].max() == pytest.approx(pk, rel=0.3)
        assert speed[before].max() < 0.1 * pk
        # and it turns by about the saccade's amplitude (deg)
        i0, i1 = np.flatnonzero(t <= t0)[-1], np.flatnonzero(t <= t0 + s["duration_ms"] + 20)[-1]
        moved = math.hypot(ang_h[i1] - ang_h[i0], ang_v[i1] - ang_v[i0])
        assert moved == pytest.approx(a, rel=0.25)


def test_remap_difference_is_abs_of_predicted_minus_actual(run):
    data, _ = run
    for e in ("left", "right"):
        p = image(data[f"/remap/{e}/predicted"]).astype(int)
        a = image(data[f"/remap/{e}/actual"]).astype(int)
        d = image(data[f"/remap/{e}/difference"]).astype(int)
        valid = p.sum(-1) > 0  # cells with a prediction (unknown ones are 0)
        match = np.abs(d - np.abs(p - a)) <= 1
        # the difference is abs(p - a) up to rounding, or 0 where either sample is invalid
        assert np.all(match[valid] | (d[valid] == 0))
        assert match[valid].mean() > 0.9 and valid.mean() > 0.5
    errs = [scalars(data[f"/remap/error/{m}"]) for m in ("homography", "mobius", "shift")]
    assert all(len(x) == 2 and np.all(np.isfinite(x)) and np.all(x >= 0) for x in errs)


def test_hemisphere_layout_against_hand_routing(tmp_path, grid):
    """Left hemisphere = right hemifield of both eyes: pixel [0, k] is the left eye's ring k at the
    sector just right of the upper vertical meridian; [0, M + k] the right eye's."""
    g, _ = grid

    class View:
        def __init__(self, per):
            self.periphery, self.fovea = per, np.zeros((g.n_fovea, 3))
            self.coeffs = C.dpft(per, g)

    rng = np.random.default_rng(0)
    left, right = rng.random((g.M, g.N, 3)), rng.random((g.M, g.N, 3))
    path = tmp_path / "h.rrd"
    with Recorder(path, recording_id="t") as rec:
        rec.set_time_ms(5)
        rec.log_views((View(left), View(right)), g)
    data = read(path)
    lh = image(data["/cortex/left_hemisphere"]).astype(float) / 255
    rh = image(data["/cortex/right_hemisphere"]).astype(float) / 255
    q = g.N // 4
    k = np.arange(g.M)
    assert lh[0, k] == pytest.approx(left[k, q - 1], abs=1 / 255)
    assert lh[0, g.M + k] == pytest.approx(right[k, q - 1], abs=1 / 255)
    assert lh[-1, k] == pytest.approx(left[k, 3 * q], abs=1 / 255)  # lower meridian, right side
    assert rh[0, k] == pytest.approx(left[k, q], abs=1 / 255)  # just left of the upper meridian
    lp = image(data["/retina/left/logpolar"]).astype(float) / 255
    assert lp == pytest.approx(left, abs=1 / 255)
    assert data["/retina/left/logpolar"]["times_ms"].tolist() == [5.0]


def test_scalars_flash_and_trace_values(tmp_path):
    from models import EyeTrace

    times = np.arange(0, 10, 0.25)
    ang = np.zeros((len(times), 2, 3))
    ang[:, 1, 0] = np.radians(times)  # right eye horizontal: 1 deg per ms
    vel = np.zeros_like(ang)
    vel[:, 0, 1] = np.radians(500.0)
    path = tmp_path / "s.rrd"
    with Recorder(path) as rec:
        rec.log_eye_trace(EyeTrace(times, ang, vel, ang))
        rec.set_time_ms(20)
        rec.log_flash((4.0, 2.0), (3.0, 1.5))
        rec.log_eye_angles(np.radians([[1, 2, 3], [4, 5, 6]]), np.zeros((2, 3)))
        with pytest.raises(ValueError):
            rec.log_flash((np.nan, 0), (0, 0))
    data = read(path)
    h = data["/eyes/right/angle/h"]
    assert h["times_ms"][:-1] == pytest.approx(times)
    assert scalars(h)[:-1] == pytest.approx(times)
    assert scalars(h)[-1] == pytest.approx(4.0) and h["times_ms"][-1] == 20
    assert scalars(data["/eyes/left/velocity/v"])[:-1] == pytest.approx(500.0)
    assert data["/flash/true"]["cols"]["Points2D:positions"][0] == [pytest.approx([4.0, -2.0])]
    assert data["/flash/perceived"]["cols"]["Points2D:positions"][0] == [pytest.approx([3.0, -1.5])]


def test_grid_overlay_radii(grid):
    g, ppu = grid
    strips = grid_strips(g, (IMAGE_SIZE, IMAGE_SIZE), ppu)
    assert len(strips) == g.M + 1 + g.N
    centre = np.array([IMAGE_SIZE / 2, IMAGE_SIZE / 2])
    r_fovea = np.linalg.norm(strips[0] - centre, axis=1)
    assert r_fovea == pytest.approx(math.tan(math.radians(3.0)) * ppu)  # the env's 3 deg fovea
    # every sector edge runs radially from the foveal edge to the outermost ring
    outer = np.linalg.norm(strips[g.M] - centre, axis=1)[0]
    for s in strips[g.M + 1:]:
        assert np.linalg.norm(s - centre, axis=1) == pytest.approx([r_fovea[0], outer])


def test_cli_writes_recording(tmp_path):
    p = tmp_path / "cli.rrd"
    assert main(["visualize", "--out", str(p), "--steps", "1", "--image-size", "64", "--fixation-ms", "50"]) == 0
    data = read(p)
    assert "/eyes/left/image" in data and image(data["/eyes/left/image"]).shape == (64, 64, 3)
    assert "/remap/right/difference" in data


@pytest.mark.parametrize("argv", [["visualize", "--steps", "1"],  # neither --out nor --spawn
                                  ["visualize", "--out", "x.rrd", "--steps", "0"],
                                  ["visualize", "--out", "x.rrd", "--task", "nope"]])
def test_cli_bad_options(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    assert not (tmp_path / "x.rrd").exists()
