"""DrQ-style SAC (issue 38 item 3): random shifts of the cortical map and the critic-trained encoder."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")


def _map(B=3, M=5, N=7, C=2, seed=0):
    return torch.as_tensor(np.random.default_rng(seed).normal(size=(B, 2, M, N, C)).astype(np.float32))


def test_sector_shift_is_a_circular_roll_and_ring_shift_is_drq_padded_crop():
    """Against independent constructions: torch.roll along the sector axis (the map wraps around in
    angle), and DrQ's replicate-pad-then-crop along the ring axis (Kostrikov et al. 2021)."""
    from torch.nn import functional as F

    from experiments.agents.augment import shift_cortical

    x = _map()
    B, _, M, N, _ = x.shape
    rings, sectors = torch.tensor([0, 1, -2]), torch.tensor([3, -1, 9])
    y = shift_cortical(x, rings, sectors)
    for b in range(B):
        r, s = int(rings[b]), int(sectors[b])
        rolled = torch.roll(x[b], shifts=s, dims=2)  # (2, M, N, C): circular in angle
        img = rolled.permute(0, 3, 1, 2).reshape(1, -1, M, N)  # rings as the image's rows
        pad = 2
        padded = F.pad(img, (0, 0, pad, pad), mode="replicate")
        crop = padded[:, :, pad - r:pad - r + M].reshape(2, -1, M, N).permute(0, 2, 3, 1)
        torch.testing.assert_close(y[b], crop, rtol=0, atol=0)
    # a whole turn is no shift; a sector shift keeps each ring's values (a rotation about the fovea)
    torch.testing.assert_close(shift_cortical(x, torch.zeros(B), torch.full((B,), N)), x, rtol=0, atol=0)
    z = shift_cortical(x, torch.zeros(B), torch.tensor([1, 2, 3]))
    torch.testing.assert_close(z.sort(dim=3).values, x.sort(dim=3).values, rtol=0, atol=0)


def test_zero_shift_is_identity_and_random_shifts_are_seeded():
    from experiments.agents.augment import random_shifts, shift_cortical

    x = _map(B=16)
    torch.testing.assert_close(shift_cortical(x, torch.zeros(16), torch.zeros(16)), x, rtol=0, atol=0)
    assert random_shifts(x, 0) is x
    a = random_shifts(x, 2, torch.Generator().manual_seed(5))
    b = random_shifts(x, 2, torch.Generator().manual_seed(5))
    c = random_shifts(x, 2, torch.Generator().manual_seed(6))
    torch.testing.assert_close(a, b, rtol=0, atol=0)
    assert not torch.equal(a, c) and not torch.equal(a, x)
    torch.manual_seed(1)
    d = random_shifts(x, 1)
    torch.manual_seed(1)
    torch.testing.assert_close(random_shifts(x, 1), d, rtol=0, atol=0)
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="pad must be"):
            random_shifts(x, bad)
    with pytest.raises(ValueError, match="one shift per sample"):
        shift_cortical(x, torch.zeros(2), torch.zeros(16))


def _policy(critic_encoder=True):
    pytest.importorskip("stable_baselines3")
    from gymnasium import spaces

    from experiments.agents.sb3 import CorticalSAC

    M, N = 4, 6
    obs = spaces.Dict({"cortical": spaces.Box(0, 1, (2, M, N, 3), np.float32),
                       "eyes": spaces.Box(-1, 1, (2, 3), np.float32)})
    act = spaces.Box(-1, 1, (2,), np.float32)
    vec = np.random.default_rng(0).uniform(-0.9, 0.9, (M * N, 2)).tolist()
    torch.manual_seed(0)
    pol = CorticalSAC(obs, act, lambda _: 1e-3, saccade_vectors=vec, channels=(4,), logit_gain=10.0,
                      critic_encoder=critic_encoder)
    batch = {k: torch.as_tensor(np.random.default_rng(1).uniform(0, 1, (5, *s.shape)).astype(np.float32))
             for k, s in obs.spaces.items()}
    return pol, batch


def test_critic_loss_trains_the_shared_encoder_and_actor_loss_does_not():
    """DrQ / SAC-AE wiring: one encoder, the critic's; gradients of a critic loss reach it, those of the
    actor's outputs do not, and neither the actor's optimizer nor the target critic holds it."""
    pol, obs = _policy()
    enc = pol.critic.features_extractor
    assert pol.actor.features_extractor is enc and pol.critic_target.features_extractor is not enc
    enc_ids = {id(p) for p in enc.parameters()}
    assert not enc_ids & {id(p) for g in pol.actor.optimizer.param_groups for p in g["params"]}
    assert enc_ids <= {id(p) for g in pol.critic.optimizer.param_groups for p in g["params"]}

    mean, log_std, _ = pol.actor.get_action_dist_params(obs)
    (mean.pow(2).sum() + log_std.sum()).backward()
    assert all(p.grad is None for p in enc.parameters())
    assert pol.actor.mu.weight.grad.abs().sum() > 0 and pol.actor.log_std.weight.grad.abs().sum() > 0

    pol.zero_grad()
    q1, q2 = pol.critic(obs, torch.zeros(5, 2))
    ((q1 - 1.0) ** 2 + (q2 - 1.0) ** 2).mean().backward()
    conv = enc.encoder.conv[0].conv.weight
    assert conv.grad is not None and conv.grad.abs().sum() > 0
    assert all(p.grad is None for p in (pol.actor.mu.weight, pol.actor.log_std.weight))


def test_default_sac_policy_is_unchanged_and_bad_option_is_refused():
    from experiments.agents.sb3 import _DetachedCellActor, plan_run

    pol, _ = _policy(critic_encoder=False)
    assert not isinstance(pol.actor, _DetachedCellActor)
    assert pol.actor.features_extractor is not pol.critic.features_extractor
    with pytest.raises(ValueError, match="critic_encoder must be"):
        _policy(critic_encoder="yes")
    hp = {"policy": "cortical-sac", "n_timesteps": 10}
    assert "augment" not in plan_run("sac", "fixate", hp)
    assert plan_run("sac", "fixate", {**hp, "augment": {"pad": 2}})["augment"] == {"pad": 2}
    for bad in ({"pad": 0}, {"pad": 1.5}, {"pads": 1}, 3):
        with pytest.raises(ValueError, match="augment must be"):
            plan_run("sac", "fixate", {**hp, "augment": bad})
    with pytest.raises(ValueError, match="applies to SAC"):
        plan_run("ppo", "fixate", {"policy": "cortical-cell", "augment": {"pad": 1}})
