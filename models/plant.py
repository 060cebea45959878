"""The oculomotor plant in MuJoCo: each eye joint moved by a torque through the orbit's elastic and
viscous forces and the globe's inertia, driven by the brainstem's pulse-step command.

The plant (Robinson 1964, J Physiol 174:245; Robinson 1981, Annu Rev Neurosci 4:463) is
``I q'' + B q' + K q = tau`` with the time constants ``T1`` (elastic, 150 ms: Robinson 1964) and
``T2`` (a few ms; default the burst generator's ``BurstGenerator.plant_t2_ms``): each eye joint's
stiffness and damping are ``K = I / (T1 T2)``, ``B = K (T1 + T2)`` for its inertia ``I``. The
servos of :mod:`models.servo` are off; the only drive is a torque motor fed the pulse-step
``K (N + T1 N')`` (Robinson 1975), written on the commanded trajectory as ``K q + B q' + I q''``
(:func:`models.servo_setpoints`, the same code for both engines). ``pulse_gain`` scales the pulse
against the step (1 = matched): a mismatch gives post-saccadic drift (Bahill, Clark & Stark 1975,
Math Biosci 26:303; Kapoula, Robinson & Hain 1986, Vision Res 26:735). Nothing closes a loop on
the measured eye.

The derivation, the abducting/adducting command, the post-offset tail (``v T2``, 0.22 deg from
30 deg/s) and the settle rule: docs/head.md ("Head and oculomotor", section "The orbital plant").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from conformal import checks

__all__ = ["OrbitalPlant", "EYE_DRIVES"]

#: How the eye joints are driven: ``"plant"`` (torques through the orbital plant: the physics'
#: answer) or ``"servo"`` (stiff position servo with feed-forward: exact, noise-free pointing).
EYE_DRIVES = ("plant", "servo")


@dataclass(frozen=True)
class OrbitalPlant:
    """Time constants of the eye plant and the brain's pulse against them (see the module docstring).

    t1_ms : the long (elastic) time constant, 20-1000 ms (Robinson 1964: ~150 ms).
    t2_ms : the short time constant, 0.5-50 ms; None: the burst generator's ``plant_t2_ms``.
    pulse_gain : the pulse's size against the one matched to ``t1_ms`` (0.2-5; 1 = matched).
    """

    t1_ms: float = 150.0
    t2_ms: float | None = None
    pulse_gain: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "t1_ms", checks.real("t1_ms", self.t1_ms, 20.0, 1000.0))
        if self.t2_ms is not None:
            object.__setattr__(self, "t2_ms", checks.real("t2_ms", self.t2_ms, 0.5, 50.0))
        object.__setattr__(self, "pulse_gain", checks.real("pulse_gain", self.pulse_gain, 0.2, 5.0))

    def install(
        self, model, dof_adr: np.ndarray, joint_ids: np.ndarray, servo_actuators: np.ndarray, t2_ms: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Give ``model``'s eye joints this plant and switch their servos off (in place).

        ``dof_adr`` / ``joint_ids``: the eye joints' dofs and ids; ``servo_actuators``: the position and
        velocity actuators to silence; ``t2_ms``: the plant's short time constant where ``t2_ms`` is
        None. Returns the brain's model of the plant for the command: inertia, stiffness and damping
        (each (n, n), n eye joints), with the pulse scaled by ``pulse_gain``."""
        import mujoco

        t1, t2 = self.t1_ms * 1e-3, (self.t2_ms if self.t2_ms is not None else t2_ms) * 1e-3
        data = mujoco.MjData(model)
        M = np.zeros((model.nv, model.nv))
        mujoco.mj_forward(model, data)  # at qpos0: primary position
        mujoco.mj_fullM(model, data, M)
        inertia = np.diag(M)[dof_adr]
        K = inertia / (t1 * t2)
        B = K * (t1 + t2)
        model.jnt_stiffness[joint_ids] = K
        model.dof_damping[dof_adr] = B
        model.actuator_gainprm[servo_actuators, :] = 0.0
        model.actuator_biasprm[servo_actuators, :] = 0.0
        g = self.pulse_gain
        # command K (N + g T1 N') with N = q + T2 q': K q + K (T2 + g T1) q' + g K T1 T2 q''
        return (g * M[np.ix_(dof_adr, dof_adr)], np.diag(K), np.diag(K * (t2 + g * t1)))
