"""How the head's physics follows an eye command, in two timesteps: the orbital plant's torques
(``Head(eye_drive="plant")``, the default: :mod:`models.plant`) or the eye servo (``"servo"``).

Eye joints are driven by actuators (``models/head.xml``): a position servo plus a velocity
set-point and a torque feed-forward per joint (natural frequency 2000 rad/s, critically damped).
With the plant the servo's gains are zero and the feed-forward motor carries the pulse-step torque
``I a + B v + K q`` of :func:`servo_setpoints` (its ``stiffness`` and ``damping``); the timesteps
and the tabulation below are the same for both.

* fixation (no saccade in flight, or before a plan's onset): the set-points are constant, so the
  physics runs in C, ``mj_step(nstep=...)``, at ``timestep_ms`` (default 1 ms; ~5 us per step,
  ~1.5 ms per 300 ms). With the implicitfast integrator the servo is stable up to ~2.4 ms
  (omega dt < 4.8) and at 1 ms its discrete poles have modulus 0.45 (well damped).
* saccades: the set-points of every physics step are tabulated once at onset
  (:func:`servo_setpoints`) and fed from a tight loop, at ``saccade_timestep_ms`` (default 0.25 ms)
  until the saccade's offset and at ``timestep_ms`` through the slow settle tail (the plant's and
  vergence's), which is taken in closed form once the eyes are slow (:mod:`models.linear_tail`; so
  are long holds) unless a trace is recorded. The velocity set-point is the planned displacement over the step divided by the
  step, so tracking is exact up to the solver (measured < 1e-4 deg during the movement at 0.1-1
  ms). The saccade step only limits how finely recorded traces resolve the velocity profile: peak
  velocity is the mean over the first step (5 deg saccade: -0.27 / -0.54 / -1.0 / -1.9 % at 0.1 /
  0.25 / 0.5 / 1 ms) and the 20 deg/s offset is seen up to one step late (+0.1 / +0.3 / +0.6 / +1.4
  ms) -- hence 0.25 ms by default.

:func:`servo_setpoints` is the servo law of both engines: ``models.Head`` (through :class:`EyeServo`)
and the batched env's MuJoCo Warp physics (``envs.batched_physics``, at 1 ms with one inertia per
joint) compute their set-points with it.
"""

from __future__ import annotations

import numpy as np

from conformal import checks

from ._gl import mujoco
from .linear_tail import LinearTail

__all__ = ["EyeServo", "servo_setpoints", "DEFAULT_TIMESTEP_MS", "DEFAULT_SACCADE_TIMESTEP_MS"]

#: Physics timestep while no saccade is in flight (constant set-points, stepped in C).
DEFAULT_TIMESTEP_MS = 1.0
#: Physics timestep during saccades (tabulated set-points).
DEFAULT_SACCADE_TIMESTEP_MS = 0.25
#: The finest physics timestep accepted (100 steps per millisecond).
MIN_TIMESTEP_MS = 0.01
#: The longest stretch of simulated time one call may ask for (``step_ms``, ``settle_ms``,
#: ``latency_ms``, ``duration_ms``, ``before_ms``/``after_ms``): one minute, far beyond any fixation
#: (180-320 ms) or saccade latency, so that a typo cannot run for hours.
MAX_STEP_MS = 60_000


def _ms(name: str, value, lo: int = 0) -> int:
    """A whole number of milliseconds in [lo, MAX_STEP_MS] (``2.5`` raises, never truncates)."""
    return checks.integer(name, value, lo, MAX_STEP_MS, hint="times are whole milliseconds")


def _substeps(timestep_ms, name: str) -> int:
    """Physics steps per millisecond for ``timestep_ms`` (which must divide 1 ms, >= 0.01 ms)."""
    ts = checks.real(name, timestep_ms, MIN_TIMESTEP_MS, 1.0, hint="it must divide 1 ms: 1, 0.5, 0.25, 0.1, ...")
    k = int(round(1.0 / ts))
    if k < 1 or abs(k * ts - 1.0) > 1e-9:
        raise ValueError(f"{name} must divide 1 ms (1, 0.5, 0.25, 0.2, 0.1, ...), got {timestep_ms}")
    return k


def servo_setpoints(q, dt_s, inertia, out=None, stiffness=None, damping=None, end=None):
    """The eye servo's set-points for the physics steps j = 0..T-1 of commanded trajectories.

    ``q`` (n, T + 2, 6): the commanded joint angles at the step boundaries t_(-1), t_0, ..., t_T
    (t_(-1) a virtual step before the first, where the command is still at rest); ``dt_s`` (T + 1,)
    the lengths of those steps (s); ``inertia`` (6, 6) the eye joints' inertia. Returns (n, T, 18):
    per step the position set-point ``q_j``, the velocity set-point ``v_j = (q_(j+1) - q_j) / dt_j``
    (so the semi-implicit integrator lands on the command) and the inverse-dynamics feed-forward
    torque ``I (v_j - v_(j-1)) / dt_j``.

    With ``stiffness`` and ``damping`` (6, 6; ``models.OrbitalPlant.install``) the feed-forward is the
    torque that moves the orbital plant along the command, ``I a_j + B v_j + K q_j`` (the pulse-step of
    :mod:`models.plant`; ``v_j`` the velocity after the step, as MuJoCo integrates joint damping
    implicitly): with the servos off it is the only drive, the position and velocity set-points unused.

    ``end`` (n,) integers, optional: the boundary ``q[:, end]`` where each command reaches its endpoint
    (the plan's snap onto it; ``q[:, end:]`` all hold it; default ``T + 1``, the last). The steps from
    there on hold the endpoint: it is their position set-point, with no velocity and no feed-forward. With the plant the snap
    step itself (the step ending at ``end``) is held too: the plant gets the step ``K q_end`` alone, no
    pulse, and settles by itself. Both engines' rule, written here once.

    The arrays are numpy arrays (``models.Head``) or torch tensors on one device (the batched env
    computes its worlds' set-points where its physics runs): the same operations on either. ``out``
    (n, T, 18), optional: written in place (and returned), in its own dtype; by default a new float64
    numpy array."""
    v = (q[:, 1:] - q[:, :-1]) / dt_s[:, None]
    a = (v[:, 1:] - v[:, :-1]) / dt_s[1:, None]
    n, k, T = q.shape[0], q.shape[2], q.shape[1] - 2
    if out is None:
        out = np.empty((n, T, 3 * k))
    out[:, :, :k] = q[:, 1:-1]
    out[:, :, k : 2 * k] = v[:, 1:]
    out[:, :, 2 * k :] = a @ inertia.T
    if stiffness is not None:
        out[:, :, 2 * k :] += q[:, 1:-1] @ stiffness.T + v[:, 1:] @ damping.T
    if end is None:
        if stiffness is None:
            return out
        end = last = T + 1  # every command ends at the last boundary: the plant's last step is held
    else:
        last = end[:, None]
    # step j ends at boundary j + 1 of q[:, 1:] (index j + 2 of q): held from end - 1 on, from end - 2 with the plant
    steps = (np.arange(T) if isinstance(q, np.ndarray) else _torch_arange(q, T))[None, :]
    held = steps >= last - (2 if stiffness is not None else 1)  # (n or 1, T) booleans, numpy or torch
    out[:, :, k:] *= ~held[:, :, None]
    rows = np.arange(n) if isinstance(q, np.ndarray) else _torch_arange(q, n)
    q_end = q[rows, end][:, None, :]  # (n, 1, k)
    out[:, :, :k] = out[:, :, :k] * ~held[:, :, None] + held[:, :, None] * q_end
    if stiffness is not None:
        out[:, :, 2 * k :] += held[:, :, None] * (q_end @ stiffness.T)  # the step that holds the endpoint
    return out


def _torch_arange(q, n: int):
    import torch

    return torch.arange(n, device=q.device)


class EyeServo:
    """The physics of one head's eyes following its commands (see the module docstring).

    ``k_fix`` / ``k_sac``: physics steps per ms during fixation / saccades; ``qadr``, ``vadr``: the
    eye joints' addresses in ``qpos`` / ``qvel``; ``ctrl``: the 18 eye set-points' slice (or indices)
    of ``data.ctrl`` (position, velocity, feed-forward of the six joints)."""

    def __init__(
        self,
        model,
        data,
        k_fix: int,
        k_sac: int,
        qadr: np.ndarray,
        vadr: np.ndarray,
        ctrl,
        plant: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    ) -> None:
        self.model, self.data = model, data
        self.k_fix, self.k_sac = k_fix, k_sac
        self.dt_fix, self.dt_sac = 1e-3 / k_fix, 1e-3 / k_sac
        self.qadr, self.vadr, self.ctrl = qadr, vadr, ctrl
        self.plant = plant  # the command's (inertia, stiffness, damping) of the orbital plant; None: the servo
        self._M = np.zeros((model.nv, model.nv))
        self._table: dict | None = None
        #: the slow stretches (settle tail, holds) in closed form (``models.linear_tail``); None: stepped
        lin = LinearTail(model, data, ctrl, vadr)
        self.linear: LinearTail | None = lin if lin.usable else None  # not of the linear form: stepped

    def hold_controls(self, angles: np.ndarray) -> np.ndarray:
        """The 18 eye controls holding ``angles`` (2, 3): the servo's position set-points, or the
        plant's tonic torque ``K q`` (the step alone)."""
        u = np.zeros(18)
        u[:6] = angles.ravel()
        if self.plant is not None:
            u[12:] = self.plant[1] @ u[:6]
        return u

    def forget(self) -> None:
        """Drop the tabulated saccade and the closed form's map (a reset or a new state)."""
        self._table = None
        if self.linear is not None:
            self.linear.forget()

    def rest(self) -> None:
        """Back to the fixation timestep (between calls)."""
        self.model.opt.timestep = self.dt_fix

    def hold(self, angles: np.ndarray, t0_ms: int, n_ms: int, rec: list | None) -> None:
        """``n_ms`` milliseconds with constant set-points holding ``angles`` (2, 3): in closed form while
        the eyes are slow (:mod:`models.linear_tail`), else stepped in C a millisecond at a time; with
        ``rec``, append (time, qpos, qvel, command) at every step."""
        if n_ms <= 0:
            return
        m, d, k = self.model, self.data, self.k_fix
        m.opt.timestep = self.dt_fix
        u = self.hold_controls(angles)
        d.ctrl[self.ctrl] = u
        hold = angles.ravel().copy()
        n, i = n_ms * k, 0
        while i < n:
            if self.linear is not None:
                done, states = self.linear.run(np.broadcast_to(u, (n - i, u.size)), rec is not None)
                if rec is not None and done:
                    self._record(rec, t0_ms + (i + 1 + np.arange(done)) / k, states, np.broadcast_to(hold, (done, 6)))
                i += done
                if i == n:
                    break
            step = n - i if self.linear is None else k  # a millisecond, then the closed form is tried again
            if rec is None:
                mujoco.mj_step(m, d, nstep=step)
            else:
                for j in range(step):
                    mujoco.mj_step(m, d)
                    rec.append((t0_ms + (i + j + 1) / k, d.qpos[self.qadr].copy(), d.qvel[self.vadr].copy(), hold))
            i += step

    def _record(self, rec: list, times, states: np.ndarray | None, planned) -> None:
        """Append the closed form's states (steps, 2 nv) to a recorded trace's rows."""
        assert states is not None, "LinearTail.run(record=True) returns the states"
        nv = self.model.nv
        q, v = states[:, self.qadr], states[:, nv + np.asarray(self.vadr)]
        rec.extend(zip(times, q, v, np.array(planned, copy=True)))

    def table(self, plan) -> dict:
        """Per-physics-step set-points for the whole of ``plan``, computed once at its onset.

        Steps are ``saccade_timestep_ms`` long from onset until the whole millisecond after the
        main-sequence offset (speed < 20 deg/s), then ``timestep_ms`` long through the slow settle
        tail to ``plan.end_ms``; the servo's feed-forward uses the eye block of the mass matrix at onset (its
        change over a saccade is < 0.3 %), and the position servo corrects what is left; the plant's
        torque uses the brain's model of the plant (``models.plant``) and nothing corrects it.
        """
        k_sac, k_fix = self.k_sac, self.k_fix
        span = plan.end_ms - plan.onset_ms
        fine_ms = min(span, int(np.ceil(plan.duration_ms)) + 1)
        t = np.concatenate(
            [np.arange(-1, fine_ms * k_sac + 1) / k_sac, fine_ms + np.arange(1, (span - fine_ms) * k_fix + 1) / k_fix]
        )
        q = plan.angles(plan.onset_ms + t).reshape(-1, 6)
        if self.plant is None:
            mujoco.mj_fullM(self.model, self.data, self._M)
            u = servo_setpoints(q[None], np.diff(t) * 1e-3, self._M[np.ix_(self.vadr, self.vadr)])[0]
        else:
            I, K, B = self.plant
            # the last step is the plan's snap onto its endpoint (the last settle_deg): held (servo_setpoints)
            u = servo_setpoints(q[None], np.diff(t) * 1e-3, I, stiffness=K, damping=B)[0]
        return {
            "plan": plan,
            "u": u,
            "t": plan.onset_ms + t[2:],
            "q": q[2:],
            "fine_steps": fine_ms * k_sac,
            "fine_ms": fine_ms,
        }

    def saccade(self, plan, t0_ms: int, until_ms: int, rec: list | None) -> None:
        """Step the saccade in flight from ``t0_ms`` to ``until_ms`` (<= ``plan.end_ms``)."""
        tab = self._table
        if tab is None or tab["plan"] is not plan:
            tab = self._table = self.table(plan)
        m, d, ctrl, u = self.model, self.data, self.ctrl, tab["u"]
        fine, fine_ms = tab["fine_steps"], tab["fine_ms"]

        def index(ms):  # first table row of absolute millisecond ``ms``
            r = ms - plan.onset_ms
            return r * self.k_sac if r <= fine_ms else fine + (r - fine_ms) * self.k_fix

        j0, j1 = index(t0_ms), index(until_ms)
        lin = self.linear
        j = j0
        while j < j1:
            if j == j0 or j == fine:
                m.opt.timestep = self.dt_sac if j < fine else self.dt_fix
            # the settle tail, once the eyes are slow: in closed form (models.linear_tail)
            if lin is not None and j >= fine:
                done, states = lin.run(u[j:j1], rec is not None)
                if done:
                    if rec is not None:
                        self._record(rec, tab["t"][j : j + done], states, tab["q"][j : j + done])
                    j += done
                    continue
            d.ctrl[ctrl] = u[j]
            mujoco.mj_step(m, d)
            if rec is not None:
                rec.append((tab["t"][j], d.qpos[self.qadr].copy(), d.qvel[self.vadr].copy(), tab["q"][j].copy()))
            j += 1
        if until_ms >= plan.end_ms:
            self._table = None
