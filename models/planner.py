"""The brain's side of N heads at once: their oculomotor states and saccade planning as arrays.

``envs.BatchedBinocularSaccade`` plans one saccade per world per step. Building a
``models.SaccadePlan`` per world costs about a millisecond of Python, which alone would cap 4096
worlds near 1,000 env-steps/s; :class:`BatchedPlanner` plans all worlds at once:

* the plan of ``Head.plan_saccade`` (and ``plan_saccade_to`` for vergence actions): the
  retinotopic displacement at the current fixation distance, the fixation angles of both eyes
  (Listing torsion), the amplitude, endpoint noise drawn from each world's own generator;
* the trajectory, efference copies and eye-position signal of each plan: ``models.SaccadePlans``,
  the same code ``models.SaccadePlan`` runs for one head.

The geometry (fixation angles, retinotopic targets, the noisy endpoint) is :mod:`models.eye_kinematics.fixation`'s,
which ``models.Head`` uses for one head; the sequence of checks and draws follows ``Head``'s, so
plans and random streams agree with the single head's (``tests/test_batched_planner.py``: < 1e-9
rad and exact integer times). Saccades that would leave the oculomotor range are shortened by
:func:`plan_clipped`'s bisection, all such worlds at once. Vergence actions combined with endpoint
noise are planned with ``Head``'s own code on the one scratch head, brought to each such world's
state through ``Head.set_state``.
"""

from __future__ import annotations

import numpy as np

from .eye_kinematics import (
    NULL_SACCADE,
    OculomotorRangeError,
    cyclopean_amplitude,
    displaced,
    fixation_batch,
    noisy_endpoints,
)
from .oculomotor import SaccadePlan
from .oculomotor_state import OculomotorState
from .saccade_plans import SaccadePlans
from .simulation import Head

__all__ = ["BatchedPlanner", "SettledReset", "plan_clipped"]


def plan_clipped(head: Head, h: float, v: float, factor: float) -> tuple[SaccadePlan, bool]:
    """Plan the saccade by (h, v) (rad) with the fixation distance scaled by ``factor`` (a vergence
    action: ``plan_saccade_to`` the point ``factor`` times as far from the cyclopean eye); one that
    would leave the oculomotor range is shortened to its edge (bisection on its length, 10 halvings).
    Returns (plan, clipped)."""

    def attempt(scale: float):
        plan = head.plan_saccade(h * scale, v * scale)
        if factor != 1.0:
            c = head.cyclopean_position
            plan = head.plan_saccade_to(c + factor * (plan.intended_target - c))
        return plan

    try:
        return attempt(1.0), False
    except OculomotorRangeError:
        pass
    lo, hi, best = 0.0, 1.0, None
    for _ in range(10):  # bisection on the saccade's length
        mid = (lo + hi) / 2
        try:
            best, lo = attempt(mid), mid
        except OculomotorRangeError:
            hi = mid
    return (best if best is not None else head.plan_saccade(0.0, 0.0)), True


# ----------------------------------------------------------------------------------------- planner
class BatchedPlanner:
    """The oculomotor state and saccade planning of N worlds (see the module docstring).

    One ``models.Head`` (``head``) serves every world as a scratch copy: the env resets it for a world
    (scene layout, fixation, task: :class:`SettledReset`) and hands the result over with
    :meth:`take_reset`; it also plans, from the world's state, the saccades that need the single
    env's code (vergence actions with endpoint noise). State per world: the clock ``time_ms``, the
    held eye angles, the fixation point, the eye-position signal now and the last plan behind it,
    the generator of the world's endpoint noise (``rngs``) and its scene's movable objects
    (``mocap_pos``, ``mocap_quat``).
    """

    def __init__(self, head: Head, num_worlds: int) -> None:
        self.head = head
        self.num_worlds = n = int(num_worlds)
        self._centres = head.eye_centres_head
        self._c = self._centres.mean(axis=0)
        self._x, self._R = head.head_pose()
        self.time_ms = np.zeros(n, np.int64)
        self.hold = np.zeros((n, 2, 3))
        self.signal_hold = np.zeros((n, 2, 3))
        self.fix_head = np.zeros((n, 3))
        self.signal_now = np.zeros((n, 2, 3))  # the eye-position signal at time_ms
        self._table: np.ndarray | None = None  # the command tables' buffer (commands)
        self.rngs: list[np.random.Generator | None] = [None] * n
        d = head.data
        self.mocap_pos = np.zeros((n,) + d.mocap_pos.shape)
        self.mocap_quat = np.zeros((n,) + d.mocap_quat.shape)
        #: each world's joints, velocities and set-points at its last reset (what the physics loads)
        self.qpos, self.qvel, self.ctrl = (np.zeros((n,) + getattr(d, k).shape) for k in ("qpos", "qvel", "ctrl"))
        self._last: list[tuple[SaccadePlans, int] | None] = [None] * n

    @property
    def cyclopean_position(self) -> np.ndarray:
        """World position of the cyclopean eye (``models.Head.cyclopean_position`` at reset)."""
        return self._world(self._c[None])[0]

    # ------------------------------------------------------------------ state
    def take_reset(self, i: int) -> None:
        """Make world ``i``'s state that of the (just reset) head: clock, angles, fixation, signal,
        generator and the positions of the scene's movable objects."""
        head = self.head
        st = head.get_state()
        if st.plan is not None or st.signal_plan is not None:
            raise RuntimeError("take_reset expects a freshly reset head (no saccade planned yet)")
        self.time_ms[i] = st.time_ms
        self.hold[i] = st.hold
        self.signal_hold[i] = st.signal_hold
        self.fix_head[i] = st.fixation_head
        self.signal_now[i] = st.signal_hold
        self.rngs[i] = st.rng
        d = head.data
        self.mocap_pos[i], self.mocap_quat[i] = d.mocap_pos, d.mocap_quat
        self.qpos[i], self.qvel[i], self.ctrl[i] = d.qpos, d.qvel, d.ctrl
        self._last[i] = None

    def take_settled(self, worlds, settled: SettledReset, seeds, placements=None) -> None:
        """:meth:`take_reset` of many worlds at once, without the scratch head: world ``worlds[k]`` as if
        ``settled.apply(head, seeds[k])`` had reset the head (then each ``placements[k]``, a dict of
        movable object name -> world position, had been set with ``Head.set_object_position``, as a
        task's ``initialize_episode`` does). Every world gets the settled joints, set-points, clock and
        oculomotor state (the same in every world); the scene's layout is drawn from each world's own
        generator, ``numpy.random.default_rng(seed)``, which then serves its endpoint noise. Needs
        ``settled.usable`` (else reset the worlds one by one through the head)."""
        if not settled.usable:
            raise ValueError(
                "this scene's layout moves the fixation point: reset its worlds through the head "
                "(SettledReset.apply, then take_reset)"
            )
        w = np.asarray(worlds, np.intp)
        if len(seeds) != len(w) or (placements is not None and len(placements) != len(w)):
            raise ValueError(f"one seed (and placement) per world: {len(w)} worlds, {len(seeds)} seeds")
        st, data = settled._state, settled._data
        self.time_ms[w] = st.time_ms
        self.hold[w] = st.hold
        self.signal_hold[w] = st.signal_hold
        self.signal_now[w] = st.signal_hold
        self.fix_head[w] = st.fixation_head
        self.qpos[w], self.qvel[w], self.ctrl[w] = data["qpos"], data["qvel"], data["ctrl"]
        self.mocap_pos[w], self.mocap_quat[w] = settled._mocap
        layout = self.head.scene.layout
        rngs = [np.random.default_rng(int(s)) for s in seeds]
        if layout is not None and len(w):
            # each world's own draws, in the single env's order; a layout with a ``many`` method (the
            # search display's) computes the positions of all worlds at once
            many = getattr(layout, "many", None)
            if many is not None:
                names, pts = many(rngs)
            else:
                drawn = [layout(rng) for rng in rngs]
                names = tuple(drawn[0])
                pts = None
                if all(tuple(d) == names for d in drawn):
                    pts = np.array([list(d.values()) for d in drawn], float).reshape(len(w), len(names), 3)
            if pts is not None:  # one assignment for all worlds and objects
                rows = np.array([settled._mocap_id[name] for name in names], np.intp)
                self.mocap_pos[w[:, None], rows[None, :]] = pts
            else:  # (a layout whose objects vary from draw to draw)
                for i, d in zip(w, drawn):
                    for name, pos in d.items():
                        self.mocap_pos[i, settled._mocap_id[name]] = pos
        if placements is not None:
            for i, placed in zip(w, placements):
                for name, pos in placed.items():
                    pos = np.asarray(pos, float).reshape(3)
                    if not np.isfinite(pos).all():
                        raise ValueError(f"the position of {name!r} must be finite; got {pos}")
                    self.mocap_pos[i, settled.mocap_index(name)] = pos
        for i, rng in zip(w.tolist(), rngs):
            self.rngs[i] = rng
            self._last[i] = None

    def eye_position_signal(self) -> np.ndarray:
        """Every world's eye-position signal now (N, 2, 3) (``models.Head.eye_position_signal``)."""
        return self.signal_now.copy()

    def _sync_head(self, i: int) -> Head:
        """The head, brought to world i's state (to plan with the single env's code; its draws of
        endpoint noise come from the world's generator)."""
        head = self.head
        last = self._last[i]
        rng = self.rngs[i]
        if rng is None:
            raise RuntimeError(f"world {i} has no generator yet: reset it (take_reset) before planning")
        st = head.get_state()
        head.set_state(
            OculomotorState(
                time_ms=int(self.time_ms[i]),
                hold=self.hold[i].copy(),
                signal_hold=self.signal_hold[i].copy(),
                fixation_head=self.fix_head[i].copy(),
                rng=rng,
                seed=st.seed,
                signal_plan=None if last is None else SaccadePlan.from_batch(*last),
                flashes=st.flashes,
                opacity=st.opacity,
            )
        )
        return head

    # ------------------------------------------------------------------ planning
    def plan(self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray) -> tuple[SaccadePlans, np.ndarray]:
        """Plan the saccade of each of ``worlds`` (m,) by Fick increments ``hv`` (m, 2) (rad) with the
        fixation distance scaled by ``factor`` (m,), as :func:`plan_clipped` does. Returns
        the plans (in the order of ``worlds``) and whether each was shortened to the oculomotor range."""
        worlds = np.asarray(worlds, np.intp)
        m = len(worlds)
        hv = np.asarray(hv, float).reshape(m, 2)
        factor = np.asarray(factor, float).reshape(m)
        head = self.head
        noise = head.motor_noise.active
        # vergence actions with motor noise are planned by the single env's code, world by world
        fast = np.ones(m, bool) if not noise else factor == 1.0
        clipped = np.zeros(m, bool)
        hv2, factor2 = hv.copy(), factor.copy()
        f_idx = np.flatnonzero(fast)
        targets, row = None, np.full(m, -1)
        if len(f_idx):
            targets = self._targets(worlds[f_idx], hv[f_idx], factor[f_idx])
            row[f_idx] = np.arange(len(f_idx))
            _, _, _, amp, reach, ok, _ = targets
            drew = noise & reach & (amp > NULL_SACCADE)  # Head._plan_head drew before failing
            fast[f_idx[~ok & drew]] = False  # (only past the generator's 90 deg): replayed world by world
            out = f_idx[~ok & ~drew]
            if len(out):  # shortened to the range's edge: plan_clipped's bisection, all such worlds at once
                h_c, f_c, burn, odd = self._bisect(worlds[out], hv[out], factor[out])
                fast[out[odd]] = False
                keep = ~odd
                hv2[out[keep]], factor2[out[keep]] = h_c[keep], f_c[keep]
                clipped[out[keep]] = True
                for w, k in zip(worlds[out[keep]], burn[keep]):  # the draws of the attempts before the last
                    for _ in range(k):
                        self.rngs[w].normal(0.0, 1.0, size=2)  # the same stream whatever the scale
                redo = out[keep]  # their targets, from the shortened increments
                for arr, new in zip(targets, self._targets(worlds[redo], hv2[redo], factor2[redo])):
                    arr[row[redo]] = new
        batches: list[SaccadePlans] = []
        order_parts: list[np.ndarray] = []
        f_idx = np.flatnonzero(fast)
        if len(f_idx) or m == 0:
            known = None if targets is None else tuple(a[row[f_idx]] for a in targets)
            b, ok = self._plan_fast(worlds[f_idx], hv2[f_idx], factor2[f_idx], known)
            if not ok.all():  # pragma: no cover - the bisection keeps only reachable attempts
                raise RuntimeError("a clipped saccade left the oculomotor range")
            batches.append(b)
            order_parts.append(f_idx)
        slow = np.flatnonzero(~fast)
        if len(slow):
            slow_plans = []
            for k in slow:
                p, clipped[k] = plan_clipped(self._sync_head(worlds[k]), hv[k, 0], hv[k, 1], factor[k])
                slow_plans.append(p)
            batches.append(SaccadePlans.concatenate([p._batch for p in slow_plans]))
            order_parts.append(slow)
        order = np.concatenate(order_parts)
        inverse = np.empty(m, np.intp)
        inverse[order] = np.arange(m)
        plans = (
            batches[0]
            if len(batches) == 1 and np.array_equal(order, np.arange(m))
            else SaccadePlans.concatenate(batches, inverse)
        )
        return plans, clipped

    def _world(self, p_head: np.ndarray) -> np.ndarray:
        return self._x + p_head @ self._R.T

    def _head(self, p_world: np.ndarray) -> np.ndarray:
        return (p_world - self._x) @ self._R

    def _targets(self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray) -> tuple:
        """What ``Head.plan_saccade`` (then ``plan_saccade_to`` where factor != 1) aims at, before any noise:
        head-frame targets, world targets, fixation angles, amplitudes; ``reach``: the targets pass
        ``Head._plan_head``'s checks made before it draws endpoint noise (the eyes can fixate them);
        ``ok``: the plan is made (also within the burst generator's 90 deg, checked after the draw)."""
        c = self._c
        legacy = self.head.saccade_model == "legacy"
        fix = self.fix_head[worlds]
        p_head = displaced(c, fix, hv)
        intended_world = self._world(p_head)
        reach = fixation_batch(p_head, self._centres)[1]
        scaled = factor != 1.0
        if scaled.any():  # plan_saccade_to(c + factor (intended_target - c)) from the cyclopean eye
            amp1 = cyclopean_amplitude(c, fix[scaled], p_head[scaled])
            if not legacy:  # the first plan (plan_saccade) must be made too
                reach[np.flatnonzero(scaled)[np.rad2deg(amp1) > 90.0]] = False
            cw = self._world(c[None])[0]
            pw = cw + factor[scaled, None] * (intended_world[scaled] - cw)
            intended_world[scaled] = pw
            p_head[scaled] = self._head(pw)
        end, reach2, _ = fixation_batch(p_head, self._centres)
        reach &= reach2
        amp = cyclopean_amplitude(c, fix, p_head)
        ok = reach if legacy else reach & (np.rad2deg(amp) <= 90.0)
        return p_head, intended_world, end, amp, reach, ok, fix

    def _bisect(self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray) -> tuple:
        """``plan_clipped``'s bisection on the saccade's length, for all ``worlds`` at once. Returns the
        increments and factors of the last attempt made (none: a null saccade, ``plan_saccade(0, 0)``),
        the number of endpoint-noise draws the attempts before it made (``Head._plan_head`` draws at every
        attempt that reaches its target; the last attempt's draw is ``_plan_fast``'s), and the worlds
        whose attempts drew and then failed (past 90 deg: left to the single env's code)."""
        m = len(worlds)
        noise = self.head.motor_noise.active
        lo, hi, best = np.zeros(m), np.ones(m), np.full(m, -1.0)
        wins, last_drew, odd = np.zeros(m, np.int64), np.zeros(m, bool), np.zeros(m, bool)
        for _ in range(10):
            mid = (lo + hi) / 2
            _, _, _, amp, reach, ok, _ = self._targets(worlds, hv * mid[:, None], factor)
            drew = noise & reach & (amp > NULL_SACCADE)
            odd |= drew & ~ok
            wins += drew & ok
            last_drew = np.where(ok, drew, last_drew)
            best, lo, hi = np.where(ok, mid, best), np.where(ok, mid, lo), np.where(ok, hi, mid)
        none = best < 0
        return (np.where(none[:, None], 0.0, hv * best[:, None]), np.where(none, 1.0, factor), wins - last_drew, odd)

    def _plan_fast(
        self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray, targets: tuple | None = None
    ) -> tuple[SaccadePlans, np.ndarray]:
        """``Head.plan_saccade`` (then ``plan_saccade_to`` where factor != 1) for worlds whose saccade stays
        in range; returns the plans of those worlds and the mask of them. ``targets``: ``_targets`` of
        these arguments when already computed."""
        c = self._c
        p_head, intended_world, end, amp, _, ok, fix = targets or self._targets(worlds, hv, factor)
        idx = np.flatnonzero(ok)
        w = worlds[idx]
        p_head, intended_world, end, amp = p_head[idx], intended_world[idx], end[idx], amp[idx]
        end_point, noisy_end, noisy_amp = noisy_endpoints(
            c, self._centres, fix[idx], p_head, end, amp, self.head.motor_noise, [self.rngs[k] for k in w]
        )
        head = self.head
        plans = SaccadePlans(
            self.time_ms[w],
            self.hold[w],
            noisy_end,
            end,
            noisy_amp,
            amp,
            self.signal_now[w],
            self._world(end_point),
            intended_world,
            generator=head.main_sequence if head.saccade_model == "legacy" else head.generator,
            vergence=head.vergence,
            eye_position=head.eye_position,
        )
        return plans, ok

    # ------------------------------------------------------------------ execution
    def commands(self, plans: SaccadePlans, worlds: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The command tables: each plan's executed angles (m, T, 6) at every whole ms from its onset to
        its ``end_ms`` (then held), and the rows in use per plan (m,) (``SaccadePlans.command_table``).
        With ``worlds`` (m,), the worlds of the plans: the table of every world (N, T, 6), plan k's at
        world ``worlds[k]`` and each other world holding its eyes (``hold``, one row in use), and the rows
        in use per world (N,) -- what the physics follows, built in place. The tables are written into
        one buffer kept by the planner (grown as needed): they are valid until the next call (copy them
        to keep them)."""
        T = int((plans.end_ms - plans.onset_ms).max()) + 1 if plans.n else 1
        size = (plans.n if worlds is None else self.num_worlds) * T * 6
        if self._table is None or self._table.size < size:
            # twice the size: the longest table grows over an env's first steps, and each new buffer's
            # pages are given by the system as they are first written (unused headroom costs nothing)
            self._table = np.empty(2 * size)
        if worlds is None:
            return plans.command_table(self._table)
        worlds = np.asarray(worlds, np.intp)
        table, count = plans.command_table(self._table, rows=worlds, num_rows=self.num_worlds)
        idle = np.ones(self.num_worlds, bool)
        idle[worlds] = False
        table[idle] = self.hold[idle].reshape(-1, 1, 6)
        lengths = np.ones(self.num_worlds, np.int64)
        lengths[worlds] = count
        return table, lengths

    def start(self, worlds: np.ndarray, plans: SaccadePlans, advance_ms: np.ndarray) -> None:
        """Make ``plans`` the worlds' saccades and advance their clocks by ``advance_ms`` (past each plan's
        end): the eyes then hold the endpoint, the signal follows the plan (``Head.start_saccade`` then
        ``step_ms``)."""
        worlds = np.asarray(worlds, np.intp)
        if np.any(self.time_ms[worlds] + advance_ms < plans.end_ms):
            raise ValueError("advance_ms must carry every world past its saccade's end")
        self.fix_head[worlds] = self._head(plans.target)
        self.hold[worlds] = plans.end
        self.signal_hold[worlds] = plans.intended_end
        self.time_ms[worlds] += np.asarray(advance_ms, np.int64)
        self.signal_now[worlds] = plans.eye_position_signal(self.time_ms[worlds, None].astype(float))[:, 0]
        for k, i in enumerate(worlds):
            self._last[i] = (plans, k)


# ------------------------------------------------------------------------------------------- reset
class SettledReset:
    """``models.Head.reset`` without its physics, for the many resets of a batched env.

    A reset fixates the scene's default fixation point and lets the physics settle for 10 ms; only
    the eyes and neck move, so the joints, set-points, clock and oculomotor state come out the same
    in every world, whatever the layout drawn from the world's seed (the mocap bodies: a dots target,
    the search display). This captures that settled state once from ``head`` and applies it with
    each world's own layout. Usable (``usable``) when the fixation point is not moved by the layout;
    ``tests/test_batched_planner.py`` checks the result against ``Head.reset`` in every scene.
    """

    def __init__(self, head: Head) -> None:
        import mujoco

        scene = head.scene
        fix = scene.default_fixation
        moved = scene.layout(np.random.default_rng(0)).keys() if scene.layout is not None else ()
        self.usable = not (isinstance(fix, str) and fix in moved)
        m = head.model
        self._mocap_rows = {m.body(b).name: int(m.body_mocapid[b]) for b in range(m.nbody) if m.body_mocapid[b] >= 0}
        self._mocap_id = {name: self._mocap_rows[name] for name in moved}
        blank = mujoco.MjData(head.model)  # as made: reset
        self._mocap = blank.mocap_pos.copy(), blank.mocap_quat.copy()
        head.reset(seed=0)
        d = head.data
        self._data = {k: getattr(d, k).copy() for k in ("qpos", "qvel", "ctrl", "act")}
        self._time = float(d.time)
        self._state = head.get_state()

    def mocap_index(self, name: str) -> int:
        """The mocap row of the scene's movable object ``name`` (KeyError if it is not one)."""
        if name not in self._mocap_rows:
            raise KeyError(f"{name!r} is not a movable object of this scene; movable: {', '.join(self._mocap_rows)}")
        return self._mocap_rows[name]

    def apply(self, head: Head, seed: int) -> None:
        """Reset ``head`` as ``head.reset(seed=seed)`` would (same joints, set-points, clock, layout,
        visibility of objects and generator state; MuJoCo's other buffers, such as the solver's warm
        start, are not reset)."""
        import mujoco

        if not self.usable:
            head.reset(seed=seed)
            return
        st = self._state  # (a freshly reset head's: no plans, flashes or opacity changes; set_state copies arrays)
        state = OculomotorState(
            st.time_ms, st.hold, st.signal_hold, st.fixation_head, np.random.default_rng(seed), seed
        )
        d = head.data
        for k, v in self._data.items():
            getattr(d, k)[:] = v
        d.time = self._time
        d.mocap_pos[:], d.mocap_quat[:] = self._mocap
        if head.scene.layout is not None:  # Head.set_object_position of each, the names resolved once
            for name, pos in head.scene.layout(state.rng).items():
                d.mocap_pos[self._mocap_id[name]] = pos
        head.set_state(state)  # no plans; the scene's own visibility, flashes hidden
        mujoco.mj_forward(head.model, head.data)
