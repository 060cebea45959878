"""The ``observer`` theory's read-out (the model: ``psychophysics.observer``): eqs. (0)-(3) of
that module for every flash of a trial jointly, and its own looks at the target in the
displacement paradigm (its eye-position estimate and its own noise)."""

from __future__ import annotations

import math

import numpy as np

from ..observer import eye_estimate, landmark_prior, motor_cov, posterior_mean, sensory_sd_deg, suppression_log10
from . import register
from .base import ConstantsTheory

__all__ = ["Observer"]

#: Image-plane step of the finite-difference Jacobian that carries a landmark's extent to degrees
#: (1e-4 of the focal length: ~0.006 deg).
_JACOBIAN_STEP = 1e-4


class Observer(ConstantsTheory):
    """Perisaccadic localization as optimal inference (``psychophysics.observer``)."""

    name = "observer"

    def read(self, runner, obs, plan, true_pose, cfg):
        """Eqs. (0)-(3) for every flash of the trial jointly; ``gain`` is the references' weight
        along the saccade (the prior's share of the posterior), ``weight`` 0."""
        p = cfg.observer
        e_mean, e_cov = eye_estimate(plan, obs.t_mid, p.temporal_sd_ms)
        e_cov = e_cov + motor_cov(plan, obs.t_mid, p.temporal_sd_ms, p.motor_weber)
        supp = suppression_log10(plan, obs.t_mid, p)
        axes, origins = runner._pose(e_mean)
        rho, lam = self.prior(runner, plan, obs, p)
        (ta, to) = true_pose
        meas, cf, var, own = [], [], [], []  # (flash, eye, axis); var and own (flash, eye)
        maps = [runner.plain_maps(f, cfg.threshold) for f in obs.flashes]
        for f, f_maps in zip(obs.flashes, maps):
            m_e, c_e, v_e, o_e = [], [], [], []
            for e, (_, _, _, z_t, z_rel) in enumerate(f_maps):
                z = z_t + z_rel
                xf = ta[e].T @ (f["head"] - to[e])
                z_true = complex(xf[2], xf[0]) / xf[1]
                m_e.append(
                    runner._ray_to_screen_deg(origins[e], axes[e], z) if np.isfinite(z.real) else np.full(2, np.nan)
                )
                c_e.append(runner._ray_to_screen_deg(origins[e], axes[e], z_true))
                ecc = math.degrees(math.atan(abs(z))) if np.isfinite(z.real) else np.nan
                v_e.append(float(sensory_sd_deg(ecc, p, supp)) ** 2)
                o_e.append(float(sensory_sd_deg(ecc, p, supp, own=True)) ** 2)
            meas.append(m_e), cf.append(c_e), var.append(v_e), own.append(o_e)
        meas, cf, var = np.array(meas), np.array(cf), np.array(var)
        shared = var - np.array(own)  # eq. (0b): the suppression's part of each variance, common to the flashes
        post, post_cf = np.full_like(meas, np.nan), np.full_like(cf, np.nan)
        for e in range(2):
            ok = np.isfinite(meas[:, e, 0])
            for ax in range(2):
                if ok.any():
                    post[ok, e, ax] = posterior_mean(
                        meas[ok, e, ax], var[ok, e], e_cov[ax, ax], rho[ax], lam[ax], shared[ok, e]
                    )
                post_cf[:, e, ax] = posterior_mean(
                    cf[:, e, ax],
                    np.where(ok, var[:, e], p.floor_deg**2),
                    e_cov[ax, ax],
                    rho[ax],
                    lam[ax],
                    np.where(ok, shared[:, e], 0.0),
                )
        # the flash's (map 0's) sensory variance, mean over the eyes that saw it; none when neither did (the
        # row's perceived position is then NaN too: the flash was not seen)
        v0 = float(np.nanmean(var[0])) if not np.isnan(var[0]).all() else math.nan
        weight_x = lam[0] / (lam[0] + 1.0 / (v0 + e_cov[0, 0])) if lam[0] > 0 else 0.0
        reads = [([post[k, 0], post[k, 1]], [post_cf[k, 0], post_cf[k, 1]], maps[k]) for k in range(len(maps))]
        return reads, float(weight_x), 0.0

    @staticmethod
    def prior(runner, plan, obs, p) -> tuple[np.ndarray, np.ndarray]:
        """Eq. (2) from each eye's landmarks, seen after the saccade at ``obs.t_post`` through the eye
        estimate then: each landmark's screen position and extent (its image-plane covariance carried
        to degrees by the local Jacobian of the eye's ray-to-screen map); the eyes' centres and
        precisions averaged over the eyes that saw any. ``rho``, ``lam`` (2,) each."""
        per_eye = []
        if obs.ref_landmarks is not None:
            r_mean, _ = eye_estimate(plan, float(obs.t_post), p.temporal_sd_ms)
            r_axes, r_origins = runner._pose(r_mean)
            for e, (zs, covs) in enumerate(obs.ref_landmarks):
                if len(zs) == 0:
                    continue
                o, ax = r_origins[e], r_axes[e]
                xs, s2 = [], []
                for z, cov in zip(zs, covs):
                    x = runner._ray_to_screen_deg(o, ax, z)
                    h = _JACOBIAN_STEP
                    jac = np.column_stack([(runner._ray_to_screen_deg(o, ax, z + d) - x) / h for d in (h, 1j * h)])
                    xs.append(x)
                    s2.append(np.diag(jac @ cov @ jac.T))
                per_eye.append(landmark_prior(np.array(xs), np.array(s2), obs.ref_on_ms, p))
        if not per_eye:
            return np.zeros(2), np.zeros(2)
        return np.mean([r for r, _ in per_eye], axis=0), np.mean([lam for _, lam in per_eye], axis=0)

    def look(self, runner, plan, t_ms: float, zs: list, cfg) -> tuple[np.ndarray, float]:
        """The head-centred estimate (deg) of the target seen at ``t_ms`` at the retinal points ``zs``
        (each eye's) and its variance along the saccade (sensory + eye position, deg^2)."""
        p = cfg.observer
        e_mean, e_cov = eye_estimate(plan, t_ms, p.temporal_sd_ms)
        e_cov = e_cov + motor_cov(plan, t_ms, p.temporal_sd_ms, p.motor_weber)
        axes, origins = runner._pose(e_mean)
        pos = [runner._ray_to_screen_deg(origins[e], axes[e], z) for e, z in enumerate(zs) if np.isfinite(z.real)]
        if not pos:
            return np.full(2, np.nan), float("nan")
        ecc = float(np.nanmean([math.degrees(math.atan(abs(z))) for z in zs if np.isfinite(z.real)]))
        sd = float(sensory_sd_deg(ecc, p, suppression_log10(plan, t_ms, p)))
        return np.mean(pos, axis=0), sd**2 + float(e_cov[0, 0])

    def displacement_looks(self, runner, plan, looks, cfg):
        """Both looks through the observer's own eye estimate; the report's noise is its own: the
        sensory and eye-position variances of both looks."""
        (pre, v_pre), (post, v_post) = (self.look(runner, plan, t, zs, cfg) for t, zs in looks)
        return pre, post, math.sqrt(v_pre + v_post)


register(Observer())
