# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Every method the report measures, behind one small interface.

They are each registered propagator, scipy's ``solve_ivp`` (RK45, DOP853, Radau, LSODA) and, when
``mujoco`` is importable, MuJoCo's RK4 free body.

A method has one setting it sweeps (a fixed step, a tolerance or nothing) and runs a case from its
initial state to a sorted array of output times, returning ``(omega_B, q_NB)``. It runs the cases
it ``applies`` to: the free body's exact solution (``analytic``) and MuJoCo's free body the
torque-free cases, the exact gyrostat (``gyrostat``) the gyrostat cases it solves (a rotor or
coasting wheels, their momentum along a principal axis or oblique), every integrator every case (a
gyrostat case's effects through the scene, as ``auto`` would run them).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from .cases import Case
from ..core.body.rigid_body import RigidBody
from ..core.propagators import ATOL_PER_RTOL, make_propagator, PROPAGATORS
from ..core.propagators.dynamics import Dynamics
from ..core.propagators.gyrostat import free_gyrostat
from ..core.propagators.numerical import FixedStepPropagator
from ..core.scene.loader import scene_from_mapping

#: relative tolerances of the adaptive methods (``atol = rtol * ATOL_PER_RTOL``, as ``auto`` uses)
TOLERANCES = (1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-13)
#: fixed steps, as steps per rotation (``step = 2 pi / |w0| / N``)
STEPS_PER_ROTATION = (8, 16, 32, 64, 128, 256, 512, 1024, 2048)
#: MuJoCo time steps: the 100 Hz output period (or the reference spacing, if finer)
#: divided by these
MUJOCO_SUBSTEPS = (1, 2, 4, 8, 16, 32, 64)
SMOKE_TOLERANCES = (1e-5, 1e-9)
SMOKE_STEPS_PER_ROTATION = (32, 256)
SMOKE_MUJOCO_SUBSTEPS = (1, 8)
OUTPUT_PERIOD = 0.01  # s: the 100 Hz output


@dataclass(frozen=True)
class Method:
    label: str
    family: str  # torquefree_ros | scipy solve_ivp | mujoco
    setting_name: str  # step | rtol | dt | "" (no setting)
    settings: Callable[[Case, bool], tuple]  # (case, smoke) -> settings, cheapest first
    run: Callable[[Case, float | None, np.ndarray], tuple[np.ndarray, np.ndarray]]
    #: (case, setting, span) -> steps a fixed-step method would take over ``span`` seconds
    steps: Callable[[Case, float, float], float] | None = None
    #: (case) -> whether the method runs the case
    applies: Callable[[Case], bool] = lambda case: True


def torque_free(case: Case) -> bool:
    return not case.effects


def exact_gyrostat(case: Case) -> bool:
    """Whether the exact gyrostat solves the case: its effects make a free gyrostat it solves."""
    if not case.effects:
        return False  # (the free body: the analytic propagator itself)
    scene = scene_from_mapping(case.scene_mapping())
    return not isinstance(
        free_gyrostat(scene.inertia, scene.effects, case.angular_velocity), str
    )


def _propagator(case: Case, name: str, **options):
    """Build a propagator of ``name`` for the case: the free body's, or the case's scene's."""
    if not case.effects:
        return make_propagator(
            case.inertia, case.angular_velocity, case.orientation, name, **options
        )
    return scene_from_mapping(case.scene_mapping()).propagator(name, **options)


def _ours(name: str) -> Method:
    cls = PROPAGATORS[name]

    if issubclass(cls, FixedStepPropagator):

        def settings(case, smoke):
            counts = SMOKE_STEPS_PER_ROTATION if smoke else STEPS_PER_ROTATION
            return tuple(case.rotation_period / n for n in counts)

        def run(case, step, times):
            return _propagator(case, name, step=step)(times)

        return Method(
            name,
            'torquefree_ros',
            'step',
            settings,
            run,
            steps=lambda case, step, span: span / step,
        )
    if 'rtol' in cls.options:

        def run(case, rtol, times):
            return _propagator(case, name, rtol=rtol, atol=rtol * ATOL_PER_RTOL)(times)

        return Method(name, 'torquefree_ros', 'rtol', _tolerances, run)

    def run(case, _, times):
        return _propagator(case, name)(times)

    applies = exact_gyrostat if name == 'gyrostat' else torque_free
    return Method(name, 'torquefree_ros', '', lambda case, smoke: (None,), run, applies=applies)


def _tolerances(case, smoke):
    return SMOKE_TOLERANCES if smoke else TOLERANCES


def _scipy(solver: str) -> Method:
    def run(case, rtol, times):
        # the same right-hand side as the numerical propagators,
        # so the comparison is of the drivers
        if case.effects:  # the scene's: its effects bound to the body, their initial states
            propagator = _propagator(case, 'dop853')
            dynamics, x0 = propagator.dynamics, propagator.x0
        else:
            dynamics, x0 = Dynamics(RigidBody.from_inertia(case.inertia)), np.empty(0)
        y0 = np.concatenate(
            [case.angular_velocity, case.orientation / np.linalg.norm(case.orientation), x0]
        )
        solution = solve_ivp(
            lambda t, y: dynamics.derivative(t, y, 0.0),
            (0.0, float(times[-1])),
            y0,
            method=solver,
            t_eval=times,
            rtol=rtol,
            atol=rtol * ATOL_PER_RTOL,
        )
        if not solution.success:
            raise RuntimeError(solution.message)
        q = solution.y[3:7].T
        return solution.y[:3].T, q / np.linalg.norm(q, axis=1, keepdims=True)

    return Method(f'scipy {solver}', 'scipy solve_ivp', 'rtol', _tolerances, run)


_MJCF = (
    '<mujoco>\n'
    '  <option timestep="{dt!r}" integrator="RK4" gravity="0 0 0">\n'
    '    <flag contact="disable" constraint="disable"/>\n'
    '  </option>\n'
    '  <worldbody><body><freejoint/><inertial pos="0 0 0" mass="1" diaginertia="{inertia}"/>'
    '</body></worldbody>\n'
    '</mujoco>'
)
_MUJOCO_CHUNK = 100_000  # steps per compiled rollout call


def mujoco_available() -> bool:
    try:
        import mujoco.rollout  # noqa: F401
    except ImportError:
        return False
    return True


def _mujoco_base_step(case: Case) -> float:
    spacing = float(np.min(np.diff(case.times)))
    return min(OUTPUT_PERIOD, spacing)


def _mujoco_settings(case, smoke):
    return tuple(
        _mujoco_base_step(case) / k for k in (SMOKE_MUJOCO_SUBSTEPS if smoke else MUJOCO_SUBSTEPS)
    )


def _mujoco_run(case, dt, times):
    """
    Run a free body in MuJoCo (no gravity, no contacts) by its RK4 with compiled rollouts.

    Its free joint's angular velocity is in body coordinates and its quaternion is
    ``(w, x, y, z)``.
    """
    import mujoco
    import mujoco.rollout

    model = mujoco.MjModel.from_xml_string(
        _MJCF.format(dt=dt, inertia=' '.join(repr(float(i)) for i in case.inertia))
    )
    data = mujoco.MjData(model)
    q0 = case.orientation / np.linalg.norm(case.orientation)
    data.qpos[3:7] = [q0[3], q0[0], q0[1], q0[2]]
    data.qvel[3:6] = case.angular_velocity
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    steps = np.rint(np.asarray(times) / dt).astype(np.int64)
    if not np.allclose(steps * dt, times, rtol=1e-9, atol=1e-12):
        raise ValueError(f'dt: the output times are not multiples of {dt:g} s')
    out = np.empty((steps.size, state.size))
    out[steps == 0] = state
    done = 0
    while done < steps[-1]:
        count = int(min(_MUJOCO_CHUNK, steps[-1] - done))
        states, _ = mujoco.rollout.rollout(model, data, state[None], nstep=count)
        inside = (steps > done) & (steps <= done + count)
        out[inside] = states[0, steps[inside] - done - 1]
        state = states[0, -1]
        done += count
    qpos, qvel = out[:, 1: 1 + model.nq], out[:, 1 + model.nq: 1 + model.nq + model.nv]
    q_wxyz = qpos[:, 3:7]
    q = np.concatenate([q_wxyz[:, 1:], q_wxyz[:, :1]], axis=1)
    return qvel[:, 3:6], q / np.linalg.norm(q, axis=1, keepdims=True)


def all_methods(include_mujoco: bool = True) -> list[Method]:
    """Return every registered propagator, then the scipy baselines, then MuJoCo if importable."""
    methods = [
        _ours(name) for name in sorted(PROPAGATORS, key=lambda n: (not PROPAGATORS[n].exact, n))
    ]
    methods += [_scipy(solver) for solver in ('RK45', 'DOP853', 'Radau', 'LSODA')]
    if include_mujoco and mujoco_available():
        methods.append(
            Method(
                'mujoco RK4',
                'mujoco',
                'dt',
                _mujoco_settings,
                _mujoco_run,
                steps=lambda case, dt, span: span / dt,
                applies=torque_free,
            )
        )
    return methods
