"""Tests for experiments.recording: write recordings, read them back with Rerun's own reader."""

from __future__ import annotations

import math
import os
import socket
import subprocess
import sys
import time
import urllib.parse
import urllib.request
import uuid
from collections import defaultdict

import numpy as np
import pyarrow as pa
import pytest
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

import conformal as C
from experiments.__main__ import main
from experiments.recording.blueprint import SCENE_LOOK_TARGET, blueprint
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
def recorded(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "run.rrd"
    summary = record_env_run(path, steps=2, seed=3, image_size=IMAGE_SIZE, fixation_ms=120)
    return path, summary


@pytest.fixture(scope="module")
def run(recorded):
    path, summary = recorded
    return read(path), summary


@pytest.fixture(scope="module")
def run_path(recorded):
    return recorded[0]


@pytest.fixture(scope="module")
def grid():
    import envs

    ppu = 0.5 * IMAGE_SIZE / math.tan(math.radians(FOVY_DEG) / 2)
    return envs.Vision((IMAGE_SIZE, IMAGE_SIZE), ppu).grid, ppu


EXPECTED = (
    ["world/head/origin", "world/head/axes", "world/objects", "world/flashes", "flash/true", "flash/perceived",
     "flash/shift", "cortex/map", "cortex/labels",
     "saccades/amplitude_deg", "saccades/peak_velocity_deg_s", "saccades/duration_ms", "saccades/endpoint_error_deg"]
    + [f"remap/error/{m}" for m in ("homography", "mobius", "shift")]
    + ["world/scene/world/screen", "world/scene/fixation/fixation", "world/scene/target/target",
       "world/scene/head/skull", "world/scene/head/nose", "world/scene/neck"]
    + [p.format(e=e) for e in ("left", "right") for p in (
        "world/eyes/{e}/camera", "world/eyes/{e}/camera/image", "world/scene/{e}_eyeball/{e}_sclera",
        "world/eyes/{e}/position", "world/eyes/{e}/gaze", "eyes/{e}/image", "eyes/{e}/grid", "eyes/{e}/target",
        "retina/{e}/fovea", "retina/{e}/logpolar", "dpft/{e}/log_magnitude",
        "remap/{e}/predicted", "remap/{e}/actual", "remap/{e}/difference")]
    + [f"eyes/{e}/{k}/{a}" for e in ("left", "right") for k in ("angle", "velocity", "signal") for a in "hvt"]
)


@pytest.mark.slow
def test_every_entity_present(run):
    data, _ = run
    missing = [p for p in EXPECTED if "/" + p not in data]
    assert not missing, missing


@pytest.mark.slow
def test_image_shapes(run, grid):
    data, _ = run
    g, _ = grid
    _, _, p = C.fovea_indices(g)
    for e in ("left", "right"):
        assert image(data[f"/eyes/{e}/image"]).shape == (IMAGE_SIZE, IMAGE_SIZE, 3)
        assert image(data[f"/retina/{e}/logpolar"]).shape == (g.M, g.N, 3)
        assert image(data[f"/retina/{e}/fovea"]).shape == (p, p, 3)
        assert image(data[f"/dpft/{e}/log_magnitude"]).shape == (g.M, g.N, 3)  # viridis
        for kind in ("predicted", "actual", "difference"):
            assert image(data[f"/remap/{e}/{kind}"]).shape == (g.N // 2, 2 * g.M, 3)
    # both hemispheres, one above the other with CORTEX_GAP black rows between them
    from experiments.recording.recorder import CORTEX_GAP

    assert image(data["/cortex/map"]).shape == (g.N + CORTEX_GAP, 2 * g.M, 3)


@pytest.mark.slow
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


@pytest.mark.slow
def test_every_timed_entity_lies_in_the_run_and_3d_shapes(run):
    """Every non-static entity is logged inside [start, end] of simulated time; the 3-D scene has
    the head, both eyes 6.4 cm apart with unit gaze rays starting at them, and scene objects."""
    data, summary = run
    start, end = summary["start_ms"], summary["end_ms"]
    for p in EXPECTED:
        e = data["/" + p]
        if not e["static"]:
            assert len(e["times_ms"]) and start - 1e-9 <= e["times_ms"][0] and e["times_ms"][-1] <= end + 1e-9, p
    for p in ("cortex/map", "dpft/left/log_magnitude", "retina/right/logpolar"):
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


@pytest.mark.slow
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
        # the eye-position signal lags the eye: at the saccade's end it has covered less of the movement
        sig_h, sig_v = scalars(data["/eyes/left/signal/h"]), scalars(data["/eyes/left/signal/v"])
        st = data["/eyes/left/signal/h"]["times_ms"]
        j0, j1 = np.flatnonzero(st <= t0)[-1], np.flatnonzero(st <= t0 + s["duration_ms"])[-1]
        assert math.hypot(sig_h[j1] - sig_h[j0], sig_v[j1] - sig_v[j0]) < 0.8 * moved


@pytest.mark.slow
def test_remap_difference_is_signed_predicted_minus_actual(run):
    """predicted and actual share one gain (their larger maximum); the difference is predicted - actual
    on RdBu_r over [-m, m]: red where the prediction is brighter, blue where it is darker."""
    from experiments.recording.colour import colormap_lut

    data, _ = run
    lut = colormap_lut("RdBu_r").astype(int)
    for e in ("left", "right"):
        p = image(data[f"/remap/{e}/predicted"]).astype(float).mean(-1)
        a = image(data[f"/remap/{e}/actual"]).astype(float).mean(-1)
        d = image(data[f"/remap/{e}/difference"]).astype(int)
        # each difference pixel is a colour of the map: its index is 127.5 + 127.5 (p - a) / m
        idx = np.argmin(((d[..., None, :] - lut[None, None]) ** 2).sum(-1), axis=-1)
        assert np.all(((d - lut[idx]) ** 2).sum(-1) <= 12)
        valid = (p > 0) & (a > 0)
        x, y = (p - a)[valid], idx[valid] - 127.5  # both proportional to predicted - actual
        assert valid.sum() > 20 and np.std(x) > 0
        assert np.corrcoef(x, y)[0, 1] > 0.9
        big = np.abs(x) > 8
        assert big.sum() > 0 and np.all(np.sign(x[big]) == np.sign(y[big]))
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
    from experiments.recording.recorder import CORTEX_GAP

    cortex = image(data["/cortex/map"]).astype(float)
    gain = max(left.max(), right.max()) / 255  # one gain: the picture's maximum
    rh, lh = cortex[:g.N // 2] * gain, cortex[g.N // 2 + CORTEX_GAP:] * gain
    assert np.all(cortex[g.N // 2:g.N // 2 + CORTEX_GAP] == 0)
    q = g.N // 4
    k = np.arange(g.M)
    assert lh[0, k] == pytest.approx(left[k, q - 1], abs=1 / 255)
    assert lh[0, g.M + k] == pytest.approx(right[k, q - 1], abs=1 / 255)
    assert lh[-1, k] == pytest.approx(left[k, 3 * q], abs=1 / 255)  # lower meridian, right side
    assert rh[0, k] == pytest.approx(left[k, q], abs=1 / 255)  # just left of the upper meridian
    lp = image(data["/retina/left/logpolar"]).astype(float) / 255 * left.max()  # gain: its own maximum
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


@pytest.mark.slow
def test_cli_writes_recording(tmp_path):
    p = tmp_path / "cli.rrd"
    assert main(["visualize", "--out", str(p), "--steps", "1", "--image-size", "64", "--fixation-ms", "50"]) == 0
    data = read(p)
    assert "/eyes/left/image" in data and image(data["/eyes/left/image"]).shape == (64, 64, 3)
    assert "/remap/right/difference" in data


# ---------------------------------------------------------------------- reading rows back
def rows(path) -> dict[str, list[tuple[float, dict]]]:
    """entity -> [(time_ms or -inf for static, {column: value})] in logging order (sim time, then row id)."""
    out: dict[str, list] = defaultdict(list)
    for chunk in RrdReader(path).store().stream().to_chunks():
        b = chunk.to_record_batch()
        n = b.num_rows
        t = (b.column("sim_time").cast(pa.int64()).to_numpy() / 1e6 if "sim_time" in b.schema.names
             else np.full(n, -np.inf))
        rid = b.column("rerun.controls.RowId").to_pylist()
        cols = {c: b.column(c).to_pylist() for c in b.schema.names if ":" in c}
        for i in range(n):
            out[chunk.entity_path].append((float(t[i]), rid[i], {c: v[i] for c, v in cols.items() if v[i] is not None}))
    return {e: [(t, c) for t, _, c in sorted(r, key=lambda x: (x[0], x[1]))] for e, r in out.items()}


def latest(entity_rows, column: str, t_ms: float = math.inf):
    """The latest value of ``column`` at or before ``t_ms`` (Rerun's latest-at), or None."""
    val = None
    for t, cols in entity_rows:
        if t > t_ms:
            break
        if column in cols:
            val = cols[column]
    return val


def transform(entity_rows, t_ms: float = math.inf) -> tuple[np.ndarray, np.ndarray]:
    """(translation (3,), rotation (3, 3)) of a Transform3D at ``t_ms`` (mat3x3 is stored column-major)."""
    tr = np.asarray(latest(entity_rows, "Transform3D:translation", t_ms), float).reshape(3)
    m = np.asarray(latest(entity_rows, "Transform3D:mat3x3", t_ms), float).reshape(3, 3).T
    return tr, m


def rgba(packed: int) -> list[int]:
    return [(packed >> s) & 255 for s in (24, 16, 8, 0)]


# ---------------------------------------------------------------------- the MuJoCo scene in 3-D
SCENE_XML = """
<mujoco>
  <asset>
    <texture name="chk" type="2d" builtin="checker" rgb1="1 0 0" rgb2="0 0 1" width="8" height="8"/>
    <material name="textured" texture="chk" rgba="1 1 1 1"/>
    <material name="plain" rgba="0.2 0.4 0.6 1"/>
    <mesh name="tet" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 3 0.1" material="textured"/>
    <geom name="endless" type="plane" size="0 0 1" pos="0 0 -1" rgba="0 1 0 1"/>
    <geom name="collision_only" type="box" size="1 1 1" group="3"/>
    <body name="thing" pos="1 2 3" euler="10 20 30">
      <geom name="box" type="box" size="0.1 0.2 0.3" pos="0.1 0 0" euler="0 0 30" rgba="1 0 0 1"/>
      <geom name="ball" type="sphere" size="0.05" material="plain"/>
      <geom type="capsule" size="0.02 0.1" pos="0 0.3 0"/>
      <geom name="egg" type="ellipsoid" size="0.1 0.2 0.3" pos="0 0 0.5" rgba="0 0 1 0.5"/>
      <geom name="can" type="cylinder" size="0.03 0.04" pos="0 -0.3 0" euler="90 0 0" rgba="1 1 0 1"/>
      <geom name="tet" type="mesh" mesh="tet" rgba="0 1 1 1"/>
    </body>
    <body name="mover" mocap="true" pos="0 0 1">
      <geom name="dot" type="sphere" size="0.01" rgba="1 1 1 0"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def scene_run(tmp_path_factory):
    """A hand-written model with every drawn geom type, logged at t = 1 ms; then the mocap body
    moved and its hidden dot shown, logged at t = 2 ms."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(SCENE_XML)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    path = tmp_path_factory.mktemp("scene") / "scene.rrd"
    with Recorder(path, recording_id="scene") as rec:
        rec.set_time_ms(1)
        n1 = rec.log_scene(m, d)
        poses1 = {g: (d.geom_xpos[g].copy(), d.geom_xmat[g].reshape(3, 3).copy()) for g in range(m.ngeom)}
        rec.set_time_ms(2)
        assert rec.log_scene(m, d) == 0  # nothing changed: nothing logged
        d.mocap_pos[0] = [0.5, -0.5, 1.5]
        m.geom_rgba[m.geom("dot").id, 3] = 1.0
        mujoco.mj_forward(m, d)
        n2 = rec.log_scene(m, d)
        poses2 = {g: (d.geom_xpos[g].copy(), d.geom_xmat[g].reshape(3, 3).copy()) for g in range(m.ngeom)}
    return m, rows(path), (n1, n2), (poses1, poses2)


def _geom_entity(m, g) -> str:
    body = m.body(int(m.geom_bodyid[g])).name
    return f"/world/scene/{body}/{m.geom(g).name or f'geom_{g}'}"


def test_scene_geoms_kinds_sizes_and_colours(scene_run):
    """Every geom of the visible groups is one entity of the right archetype, size and colour (its
    rgba; a material's rgba; a textured material's rgba times the texture's mean); group 3 is not drawn."""
    m, data, (n1, n2), _ = scene_run
    drawn = [g for g in range(m.ngeom) if m.geom_group[g] < 3]
    assert n1 == len(drawn) + 3  # geoms + the bodies world, thing, mover
    assert n2 == 2  # the moved mocap body and its dot
    assert "/world/scene/world/collision_only" not in data
    e = {m.geom(g).name or f"geom_{g}": data[_geom_entity(m, g)] for g in drawn}
    assert set(e) == {"floor", "endless", "box", "ball", "geom_5", "egg", "can", "tet", "dot"}
    assert latest(e["floor"], "Boxes3D:half_sizes") == [pytest.approx([2, 3, 0.0005])]
    assert rgba(latest(e["floor"], "Boxes3D:colors")[0]) == [128, 0, 128, 255]  # red/blue checker, mean
    assert latest(e["endless"], "Boxes3D:half_sizes") == [pytest.approx([5, 5, 0.0005])]
    assert rgba(latest(e["endless"], "Boxes3D:colors")[0]) == [0, 255, 0, 255]
    assert latest(e["box"], "Boxes3D:half_sizes") == [pytest.approx([0.1, 0.2, 0.3])]
    assert rgba(latest(e["box"], "Boxes3D:colors")[0]) == [255, 0, 0, 255]
    assert latest(e["ball"], "Ellipsoids3D:half_sizes") == [pytest.approx([0.05] * 3)]
    assert rgba(latest(e["ball"], "Ellipsoids3D:colors")[0]) == [51, 102, 153, 255]  # the material's
    assert latest(e["geom_5"], "Capsules3D:lengths") == [pytest.approx(0.2)]
    assert latest(e["geom_5"], "Capsules3D:radii") == [pytest.approx(0.02)]
    assert latest(e["geom_5"], "Capsules3D:translations") == [pytest.approx([0, 0, -0.1])]  # centred like MuJoCo's
    assert rgba(latest(e["geom_5"], "Capsules3D:colors")[0]) == [128, 128, 128, 255]  # MuJoCo's default grey
    assert latest(e["egg"], "Ellipsoids3D:half_sizes") == [pytest.approx([0.1, 0.2, 0.3])]
    assert rgba(latest(e["egg"], "Ellipsoids3D:colors")[0]) == [0, 0, 255, 128]
    assert latest(e["can"], "Cylinders3D:lengths") == [pytest.approx(0.08)]
    assert latest(e["can"], "Cylinders3D:radii") == [pytest.approx(0.03)]
    assert rgba(latest(e["can"], "Cylinders3D:colors")[0]) == [255, 255, 0, 255]
    assert rgba(latest(e["tet"], "Mesh3D:albedo_factor")[0]) == [0, 255, 255, 255]
    # the hidden dot (alpha 0) is an empty batch at 1 ms and a sphere once shown at 2 ms
    assert latest(e["dot"], "Ellipsoids3D:half_sizes", 1.0) == []
    assert latest(e["dot"], "Ellipsoids3D:half_sizes", 2.0) == [pytest.approx([0.01] * 3)]


def test_scene_geom_world_poses_match_mujoco(scene_run):
    """Body transform composed with the geom's transform = MuJoCo's geom_xpos/geom_xmat, at both
    instants (the mocap body moved between them); the mesh's world vertices are the XML's under the
    body's pose (an independent check of the mesh frame)."""
    m, data, _, poses = scene_run
    for t, pose in zip((1.0, 2.0), poses):
        for g in range(m.ngeom):
            if m.geom_group[g] >= 3:
                continue
            ge = _geom_entity(m, g)
            tb, Rb = transform(data[ge.rsplit("/", 1)[0]], t)
            tg, Rg = transform(data[ge], t)
            assert tb + Rb @ tg == pytest.approx(pose[g][0], abs=1e-6), (ge, t)
            assert Rb @ Rg == pytest.approx(pose[g][1], abs=1e-6), (ge, t)
    assert transform(data["/world/scene/mover"], 2.0)[0] == pytest.approx([0.5, -0.5, 1.5])
    assert len(data["/world/scene/thing"]) == 1  # logged once: it never moved
    tb, Rb = transform(data["/world/scene/thing"])
    tg, Rg = transform(data["/world/scene/thing/tet"])
    verts = np.asarray(latest(data["/world/scene/thing/tet"], "Mesh3D:vertex_positions"), float)
    world = tb + (tg + verts @ Rg.T) @ Rb.T
    xml = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])
    expected = tb + xml @ Rb.T  # the XML's vertices in the body frame
    assert sorted(map(tuple, np.round(world, 6))) == sorted(map(tuple, np.round(expected, 6)))


@pytest.mark.slow
def test_dots_scene_in_the_env_recording(run):
    """The env run's recording holds the dots scene: the screen as a box, the fixation point and
    target as coloured spheres where MuJoCo puts them, 24 flash dots (hidden except when flashed),
    and the head's skull, nose, neck and eyeballs."""
    import models

    data, _ = run
    with models.Head("dots", image_size=IMAGE_SIZE) as head:
        m, d = head.model, head.data
        for name in ("screen", "fixation", "target", "skull", "nose", "left_sclera", "right_pupil"):
            g = m.geom(name).id
            cols = data[_geom_entity(m, g)]["cols"]
            shape = [c for c in cols if c.endswith(":colors")][0]
            assert rgba(cols[shape][0][0]) == pytest.approx(m.geom_rgba[g] * 255, abs=1), name
        scr = data["/world/scene/world/screen"]["cols"]
        assert scr["Boxes3D:half_sizes"][0] == [pytest.approx(m.geom_size[m.geom("screen").id])]
        assert scr["Transform3D:translation"][0] == [pytest.approx(d.geom_xpos[m.geom("screen").id])]
    # the task placed the target: its body is where its label's point says (the label LABEL_OFFSET_M above
    # or below it), at every instant
    from experiments.recording.recorder import LABEL_OFFSET_M

    lab = data["/world/labels"]
    for t, pos, labels in zip(lab["times_ms"], lab["cols"]["Points3D:positions"], lab["cols"]["Points3D:labels"]):
        tgt = data["/world/scene/target"]
        i = np.flatnonzero(tgt["times_ms"] <= t)[-1]
        got = np.asarray(pos[labels.index("target")])
        want = np.asarray(tgt["cols"]["Transform3D:translation"][i][0])
        assert got[:2] == pytest.approx(want[:2], abs=1e-6)
        assert abs(got[2] - want[2]) == pytest.approx(LABEL_OFFSET_M, abs=1e-6)
    flashes = [k for k in data if k.startswith("/world/scene/flash_") and k.count("/") == 4]
    assert len(flashes) == 24
    shown = [k for k in flashes if any(v for v in data[k]["cols"]["Ellipsoids3D:half_sizes"])]
    assert 1 <= len(shown) <= 2  # one flash per saccade in the dots scene (2 saccades)
    assert "/world/scene/neck/geom_1" in data and "Capsules3D:radii" in data["/world/scene/neck/geom_1"]["cols"]


def test_eye_cameras_pinholes_and_images(tmp_path):
    """Each eye is a Pinhole (focal length from the camera's fovy, resolution W x H, principal point
    at the centre, RUB axes) under a Transform3D equal to MuJoCo's camera pose at every logged
    instant, through a saccade; the eye image lies in the frustum, and a world point projected
    through the logged transform and pinhole lands where ``Head.project_to_pixels`` puts it."""
    import envs
    import models

    h, w, fovy = 48, 64, 60.0
    path = tmp_path / "eyes.rrd"
    poses: dict[float, list] = {}
    with models.Head("dots", image_size=(h, w), fovy_deg=fovy) as head, Recorder(path, recording_id="e") as rec:
        head.start_saccade(head.plan_saccade_to("target", latency_ms=5))
        for _ in range(40):
            rec.set_time_ms(head.time_ms)
            rec.log_head(head)
            poses[float(head.time_ms)] = [(s.camera_position.copy(), s.camera_xmat.copy()) for s in head.eye_states()]
            head.step_ms(1)
        frame = head.render()
        rec.set_time_ms(head.time_ms)
        rec.log_frame(frame, envs.Vision((h, w), head.pixels_per_unit).grid)
        t_end = float(head.time_ms)
        p_target = head.object_position("target")
        target_px = head.project_to_pixels(p_target)[:, 0]
    data = rows(path)
    f = 0.5 * h / math.tan(math.radians(fovy) / 2)
    for i, eye in enumerate(("left", "right")):
        cam = data[f"/world/eyes/{eye}/camera"]
        for t, pose in poses.items():
            tr, R = transform(cam, t)
            # float32 in Rerun (~6e-8 at 1.2 m) + the pose tolerance (1e-7) of logging on change
            assert tr == pytest.approx(pose[i][0], abs=3e-7) and R == pytest.approx(pose[i][1], abs=3e-7), (eye, t)
        assert len(cam) > 10  # logged again as the eye turned
        tr, R = transform(cam, t_end)  # the render-time pose of the frame
        assert tr == pytest.approx(getattr(frame, eye).camera_position, abs=3e-7)
        assert R == pytest.approx(getattr(frame, eye).camera_xmat, abs=3e-7)
        pin = data[f"/world/eyes/{eye}/camera/image"]
        K = np.asarray(latest(pin, "Pinhole:image_from_camera"), float).reshape(3, 3).T
        assert K == pytest.approx(np.array([[f, 0, w / 2], [0, f, h / 2], [0, 0, 1]]))
        assert latest(pin, "Pinhole:resolution") == [pytest.approx([w, h])]
        assert latest(pin, "Pinhole:camera_xyz") == [[3, 1, 6]]  # Right, Up, Back: MuJoCo's camera axes
        (fmt,) = latest(pin, "Image:format")
        assert (fmt["width"], fmt["height"]) == (w, h)
        img = np.asarray(latest(pin, "Image:buffer")[0], np.uint8).reshape(h, w, 3)
        from experiments.recording.colour import gain_scaled

        assert np.array_equal(img, gain_scaled(getattr(frame, eye).image)[0])  # the rendered image, gain-scaled
        # the target through the logged camera (RUB: looking along -z, image y down) and pinhole, in
        # Rerun's pixel coordinates (pixel centres at +0.5) = MuJoCo's (row, col) + 0.5
        x, y, z = R.T @ (p_target - tr)
        u, v = K[0, 0] * x / -z + K[0, 2], K[1, 1] * -y / -z + K[1, 2]
        assert (v, u) == pytest.approx((target_px[i][0] + 0.5, target_px[i][1] + 0.5), abs=1e-4)  # float32


# ---------------------------------------------------------------------- the blueprint
def read_blueprint(path) -> dict:
    """The blueprint stored in a recording: {"views": {id: {class, origin, name, queries, properties}},
    "containers": {id: [child ids]}, "root": id, "time_panel": {...}}."""
    r = RrdReader(path)
    (store,) = r.blueprints()
    ents: dict[str, dict] = defaultdict(dict)
    for chunk in r.stream(store=store).to_chunks():
        b = chunk.to_record_batch()
        for c in b.schema.names:
            if ":" in c:
                vals = [v for v in b.column(c).to_pylist() if v is not None]
                if vals:
                    ents[chunk.entity_path][c] = vals[-1]
    views, containers, props = {}, {}, defaultdict(dict)
    for path_, cols in ents.items():
        parts = path_.strip("/").split("/")
        if parts[0] == "view" and len(parts) == 2:
            views[f"view/{parts[1]}"] = {"class": cols["ViewBlueprint:class_identifier"][0],
                                         "origin": cols["ViewBlueprint:space_origin"][0],
                                         "name": cols.get("ViewBlueprint:display_name", [None])[0]}
        elif parts[0] == "view" and len(parts) == 3:
            props[f"view/{parts[1]}"].update(cols)
        elif parts[0] == "container":
            containers[f"container/{parts[1]}"] = cols["ContainerBlueprint:contents"]
    for vid, v in views.items():
        v["queries"] = props[vid].get("ViewContents:query", ["$origin/**"])
        v["properties"] = props[vid]
    root = "container/" + str(uuid.UUID(bytes=bytes(ents["/viewport"]["ViewportBlueprint:root_container"][0])))
    return {"views": views, "containers": containers, "root": root, "time_panel": ents.get("/time_panel", {})}


def matches(query: str, origin: str, entity: str) -> bool:
    """Rerun's entity path filter: an exact path, or ``path/**`` for the path and its subtree."""
    q = query.lstrip("+").replace("$origin", origin).strip("/")
    e = entity.strip("/")
    if q.endswith("/**"):
        base = q[:-3]
        return e == base or e.startswith(base + "/")
    return e == q


# archetypes each kind of view draws
VIEW_ARCHETYPES = {"2D": ("Image", "Points2D", "LineStrips2D", "Arrows2D"),
                   "3D": ("Transform3D", "Pinhole", "Image", "Points3D", "Arrows3D", "Boxes3D", "Ellipsoids3D",
                          "Capsules3D", "Cylinders3D", "Mesh3D", "ViewCoordinates"),
                   "TimeSeries": ("Scalars",)}


def check_blueprint(path) -> dict:
    """The blueprint's views are all reachable from the viewport; each origin is an entity (or an
    ancestor of one) of the recording; contents use only paths and ``/**``; each query shows some
    entity, of an archetype its kind of view draws; every entity with data is in some view."""
    bp = read_blueprint(path)
    entities = {e: {c.split(":")[0] for c in cols} for e, cols in
                ((e, d["cols"]) for e, d in read(path).items()) if cols and e != "/__properties"}
    reach, todo = set(), [bp["root"]]
    while todo:
        c = todo.pop()
        reach.add(c)
        todo.extend(bp["containers"].get(c, []))
    assert set(bp["views"]) <= reach, "views not in the layout"
    shown = set()
    for vid, v in bp["views"].items():
        o = v["origin"].strip("/")
        assert any(e.strip("/") == o or e.strip("/").startswith(o + "/") for e in entities), (v["name"], o)
        for q in v["queries"]:
            assert "*" not in q.replace("/**", ""), (v["name"], q)  # Rerun 0.41 has no other wildcards
            hit = [e for e in entities if matches(q, o, e)]
            assert hit, (v["name"], q)
            drawable = [e for e in hit if entities[e] & set(VIEW_ARCHETYPES[v["class"]])]
            assert drawable, (v["name"], q, "nothing this view can draw")
            shown |= set(drawable)
    assert not set(entities) - shown - {"/world"}, sorted(set(entities) - shown)
    return bp


@pytest.mark.slow
def test_run_blueprint_views_point_at_the_recording(run_path):
    bp = check_blueprint(run_path)
    views = {v["name"]: v for v in bp["views"].values()}
    scene = [v for v in views.values() if v["class"] == "3D"]
    assert len(scene) == 1 and scene[0]["origin"] == "world"
    eye = scene[0]["properties"]
    assert eye["EyeControls3D:look_target"] == [pytest.approx(SCENE_LOOK_TARGET)]
    assert views["eye angles and the eye-position signal (deg)"]["queries"] == [
        "eyes/left/angle/**", "eyes/left/signal/**", "eyes/right/angle/**", "eyes/right/signal/**"]
    for e in ("left", "right"):
        assert views[f"what the {e} eye sees now, with the retina grid"]["origin"] == f"eyes/{e}"
    assert {v["class"] for v in views.values()} == {"2D", "3D", "TimeSeries"}
    assert sum(v["origin"].startswith("remap/") for v in views.values()) == 7  # 6 maps + the errors
    assert bp["time_panel"]["TimePanelBlueprint:timeline"] == ["sim_time"]


def test_blueprint_layouts_build():
    for layout in ("run", "study"):
        assert isinstance(blueprint(layout), rrb.Blueprint)
    with pytest.raises(ValueError):
        blueprint("nope")


# ---------------------------------------------------------------------- command line: hostile input
def _usage_error(argv, capsys, monkeypatch=None) -> str:
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


BAD_NUMBERS = ["nan", "inf", "-1", "0", "1.5", "1e3", "99999999999999999999", "abc", "", "0x10"]
NUMERIC_OPTIONS = ["--steps", "--seed", "--image-size", "--fixation-ms", "--serve-seconds", "--web-port", "--grpc-port"]


@pytest.mark.adversarial
@pytest.mark.parametrize("option,value", [(o, v) for o in NUMERIC_OPTIONS for v in BAD_NUMBERS
                                          if not (o in ("--seed", "--web-port", "--grpc-port") and v == "0")
                                          # every command's --seed and --image-size (cli.options) read 1e3 as
                                          # the whole number 1000, a valid value of both
                                          and not (o in ("--seed", "--image-size") and v == "1e3")])
def test_cli_bad_numeric_option(option, value, tmp_path, monkeypatch, capsys):
    """Every numeric option rejects NaN, inf, negative, zero (where meaningless), non-integer,
    exponent, huge and non-numeric values: exit 2 with one error line naming the option."""
    monkeypatch.chdir(tmp_path)
    line = _usage_error(["visualize", "--out", "x.rrd", option, value], capsys)
    assert option in line
    assert not (tmp_path / "x.rrd").exists()


def _out_cases(tmp_path):
    (tmp_path / "adir").mkdir()
    return {"empty": "", "blank": "  ", "directory": str(tmp_path / "adir"),
            "no_parent": str(tmp_path / "no" / "x.rrd"), "unwritable": "/proc/x.rrd", "nul": "a\0b.rrd"}


@pytest.mark.adversarial
@pytest.mark.parametrize("case", ["empty", "blank", "directory", "no_parent", "unwritable", "nul"])
def test_cli_bad_out(case, tmp_path, capsys):
    line = _usage_error(["visualize", "--out", _out_cases(tmp_path)[case], "--steps", "1"], capsys)
    assert "--out" in line


@pytest.mark.adversarial
@pytest.mark.parametrize("argv,words", [
    (["visualize", "--steps", "1"], "--out"),  # nothing to write to
    (["visualize", "--spawn", "--serve"], "--serve"),
    (["visualize", "--out", "x.rrd", "--serve-seconds", "2"], "--serve-seconds"),
    (["visualize", "--out", "x.rrd", "--task", "nope"], "--task"),
    (["visualize", "--serve", "--web-port", "9555", "--grpc-port", "9555"], "differ"),
])
def test_cli_bad_combinations(argv, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert words in _usage_error(argv, capsys)
    assert not (tmp_path / "x.rrd").exists()


@pytest.mark.adversarial
def test_cli_spawn_without_display_fails_fast(tmp_path, monkeypatch, capsys):
    """``--spawn`` with no display used to hang forever: now a usage error naming --serve, at once."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.chdir(tmp_path)
    t0 = time.monotonic()
    line = _usage_error(["visualize", "--spawn", "--steps", "1"], capsys)
    assert time.monotonic() - t0 < 5
    assert "--spawn" in line and "--serve" in line and "display" in line


@pytest.mark.adversarial
@pytest.mark.parametrize("kwargs,error", [
    ({"path": ""}, ValueError), ({"path": "DIR"}, ValueError), ({"gaze_length": float("nan")}, ValueError),
    ({"image_plane_distance": 0.0}, ValueError), ({"image_plane_distance": "1"}, ValueError),
    ({"connect": "http://127.0.0.1:1/proxy"}, ValueError), ({"spawn": True}, RuntimeError),
    ({"spawn": True, "connect": "rerun+http://127.0.0.1:1/proxy"}, ValueError), ({"layout": "nope"}, ValueError),
    ({"app_id": ""}, ValueError),
])
def test_recorder_rejects_bad_arguments(kwargs, error, tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    if kwargs.get("path") == "DIR":
        kwargs = {**kwargs, "path": tmp_path}
    with pytest.raises(error):
        Recorder(**kwargs)


@pytest.mark.adversarial
@pytest.mark.parametrize("args", [("middle", np.zeros(3), np.eye(3), (8, 8), 10.0),
                                  ("left", np.full(3, np.nan), np.eye(3), (8, 8), 10.0),
                                  ("left", np.zeros(3), np.eye(3), (8, 8), -1.0),
                                  ("left", np.zeros(3), np.eye(3), (0, 8), 10.0)])
def test_log_eye_camera_rejects_bad_input(args):
    with Recorder() as rec, pytest.raises(ValueError):
        rec.log_eye_camera(*args)


# ---------------------------------------------------------------------- the headless web viewer
def _listening(port: int) -> list[str]:
    """Local addresses (hex, as in /proc/net/tcp{,6}) listening on ``port``."""
    out = []
    for name in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = open(name).read().splitlines()[1:]
        except OSError:
            continue
        for ln in lines:
            f = ln.split()
            addr, p = f[1].rsplit(":", 1)
            if int(p, 16) == port and f[3] == "0A":  # LISTEN
                out.append(addr)
    return out


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/net/tcp")
@pytest.mark.slow
def test_serve_on_loopback_only_and_stops_by_itself(tmp_path):
    """``visualize --serve --serve-seconds 2`` hosts the web viewer and its gRPC proxy on 127.0.0.1
    only, answers there, also writes ``--out``, and exits 0 by itself, leaving no server behind."""
    web, grpc = _free_port(), _free_port()
    while grpc == web:
        grpc = _free_port()
    out = tmp_path / "served.rrd"
    cmd = [sys.executable, "-m", "experiments", "visualize", "--serve", "--serve-seconds", "2", "--web-port", str(web),
           "--grpc-port", str(grpc), "--steps", "1", "--image-size", "32", "--fixation-ms", "20", "--out", str(out)]
    env = {**os.environ, "PYTHONPATH": os.getcwd()}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                            cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    try:
        first = proc.stdout.readline()
        assert first.startswith("Rerun web viewer: http://127.0.0.1:"), first + proc.stdout.read()
        url = first.split(": ", 1)[1].strip()
        assert f":{web}/" in url and urllib.parse.quote(f"rerun+http://127.0.0.1:{grpc}/proxy", safe="") in url
        for port in (web, grpc):
            addrs = _listening(port)
            assert addrs and all(a in ("0100007F", "0000000000000000FFFF00000100007F") for a in addrs), (port, addrs)
        page = urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=10).read()
        assert b"<html" in page.lower()
        rest, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, rest
    assert "recorded" in rest
    assert not _listening(web) and not _listening(grpc)
    assert "/world/eyes/left/camera/image" in read(out)


def _rrd(tmp_path) -> str:
    import rerun as rr

    path = str(tmp_path / "tiny.rrd")
    rec = rr.RecordingStream("tiny")
    rec.save(path)
    rec.log("points", rr.Points3D([[0.0, 0.0, 0.0]]))
    rec.flush()
    rec.disconnect()
    return path


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/net/tcp")
def test_two_viewers_started_at_once_never_share_an_address(tmp_path):
    """Two ``view`` commands started together on the same ports: one serves and prints the address; the
    other never prints one (it would be the first one's server), and ends with one line naming the port,
    exit 2. With ``--web-port 0 --grpc-port 0`` both serve, on ports of their own."""
    rrd = _rrd(tmp_path)
    web, grpc = _free_port(), _free_port()
    while grpc == web:
        grpc = _free_port()
    env = {**os.environ, "PYTHONPATH": os.getcwd()}
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    def start(*ports):
        return subprocess.Popen([sys.executable, "-m", "experiments", "view", rrd, "--serve-seconds", "3",
                                 "--web-port", str(ports[0]), "--grpc-port", str(ports[1])],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=root)

    for ports in ((web, grpc), (0, 0)):
        procs = [start(*ports), start(*ports)]
        results = []
        try:
            results = [p.communicate(timeout=120) + (p.returncode,) for p in procs]
        finally:
            for p in procs:
                if p.poll() is None:
                    p.kill()
                    p.wait()
        urls = [ln for out, _, _ in results for ln in out.splitlines() if ln.startswith("Rerun web viewer: ")]
        if ports == (0, 0):
            assert [rc for _, _, rc in results] == [0, 0], results
            assert len(set(urls)) == 2, urls
        else:
            assert sorted(rc for _, _, rc in results) == [0, 2], results
            assert len(urls) == 1 and f":{web}/" in urls[0], results
            err = next(e for _, e, rc in results if rc == 2)
            lines = [ln for ln in err.splitlines() if "error:" in ln]
            assert len(lines) == 1 and "Traceback" not in err, err
            assert f"port {web}" in lines[0] or f"port {grpc}" in lines[0], err
        assert not _listening(web) and not _listening(grpc)


def test_taken_port_is_one_line_naming_it(tmp_path, capsys):
    """A port another program listens on: a usage error naming it, before any server starts."""
    rrd = _rrd(tmp_path)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        with pytest.raises(SystemExit) as e:
            main(["view", rrd, "--web-port", str(port), "--grpc-port", "0", "--serve-seconds", "1"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert f"port {port} on 127.0.0.1 is in use" in err and "Traceback" not in err
