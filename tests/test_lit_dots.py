"""A flash on or near a lit dot (the target, the fixation point) is a luminance increment on it and
is seen whole, as by a person: differencing it against the lit dot would leave only its rim where it
covers the dot (issue 34: ``fit`` lost such rows)."""

from __future__ import annotations

import numpy as np
import pytest

from experiments.psychophysics import Design, TrialConfig, TrialRunner


@pytest.fixture(scope="module")
def runner():
    r = TrialRunner(TrialConfig(image_size=128))
    yield r
    r.close()


def _activity(runner, obs) -> float:
    """The flash's retinal activity (image-plane area x intensity, mean of the eyes), as
    ``TrialRunner._references_seen`` measures the references'."""
    areas = runner.retina_grid.cell_areas()[:, None]
    out = []
    for view, _, _ in obs.flashes[0]["eyes"]:
        per = np.where(view.mask, view.periphery.sum(axis=-1), 0.0)
        fov = np.where(view.fovea_mask, view.fovea.sum(axis=-1), 0.0)
        out.append(float((per * areas).sum() + fov.sum() * runner.retina_grid.fovea_spacing ** 2))
    return float(np.mean(out))


def test_a_flash_on_the_lit_target_is_seen_whole(runner, monkeypatch):
    """A flash exactly on the lit target 100 ms before the saccade gives the retina as much activity
    as the same flash 3 deg away in the open (within 25 %); differenced against the lit target (the
    path without the increment) it gives under half of it: only its rim."""
    d = Design(amplitudes_deg=(20.0,), flash_offsets_deg=((0.0, 0.0), (0.0, 3.0)), flash_times_ms=(-100,),
               name="on_target")
    on, off = d.trials()
    assert runner._lit_near(on, False) == ["target"]
    a_on, a_off = _activity(runner, runner.observe(on)), _activity(runner, runner.observe(off))
    assert a_on == pytest.approx(a_off, rel=0.25)
    monkeypatch.setattr(TrialRunner, "_lit_near", lambda self, t, two: [])
    assert _activity(runner, runner.observe(on)) < 0.5 * a_off
    # the target's opacity is restored after the increment's renders (it is lit until onset)
    assert runner.head.model.geom_rgba[runner.head.model.geom("target").id, 3] > 0


def test_far_from_lit_dots_nothing_changes(runner, monkeypatch):
    """Where a flash's image cannot overlap a lit dot the increment is the plain difference: the
    read-out is bit-identical with and without hiding the dots."""
    trial = Design(amplitudes_deg=(20.0,), flash_offsets_deg=((-4.0, -6.0),), flash_times_ms=(0,),
                   name="near").trials()[0]
    assert runner._lit_near(trial, False) == ["target"]  # 7.2 deg from the target: within LIT_NEAR_DEG
    a = runner.readout(runner.observe(trial))
    monkeypatch.setattr(TrialRunner, "_lit_near", lambda self, t, two: [])
    b = runner.readout(runner.observe(trial))
    for k in ("perceived_x_deg", "perceived_y_deg", "closed_form_x_deg"):
        assert a[k] == b[k] or (np.isnan(a[k]) and np.isnan(b[k])), k
