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
Gymnasium environments over the plant: :class:`AttitudeEnv` and :class:`AttitudeVectorEnv`.

One body (:class:`AttitudeEnv`) or a batch (:class:`AttitudeVectorEnv`).

Optional: this module needs ``gymnasium`` (the ``gym`` extra,
``pip install 'torquefree_ros[gym]'``); ``import torquefree_ros`` does not import it. Importing
this module registers the id ``torquefree_ros/Attitude-v0``:
``gymnasium.make("torquefree_ros/Attitude-v0", scene="detumble")`` and
``gymnasium.make_vec(..., num_envs=N, vectorization_mode="vector_entry_point")``.

The task (both environments)
----------------------------
A scene that takes torque (it names a ``torque_command`` effect; wheels and magnetorquers below)
is stepped by a
:class:`~torquefree_ros.Plant` at ``rate`` Hz. Step ``k`` holds the action ``tau_k`` (N m, in the
``torque_command`` effect's frame: body or inertial) over ``[t_k, t_k+1)``, ``t_k = k / rate``, and
observes the state at ``k + 1``.

* **Action space**: ``Box(-max_torque, max_torque, (3,), float64)``, ``max_torque`` the scene's
  ``torque_command.max_torque``. An action is converted to float64; a finite action outside the box
  is **clipped to the box** (the torque the scene can take; the plant itself would refuse it), and
  the clipping is reported, not silent: ``info["torque"]`` is the torque actually held and
  ``info["clipped"]`` says whether it differs from the action. An action that is not finite (NaN,
  inf), not numbers, or of the wrong shape raises ``ValueError`` naming ``action`` and changes
  nothing.
* **Wheels**: on a scene with commanded ``reaction_wheels`` (mode ``torque`` or ``speed``) the
  action is the wheels' inputs instead, one per wheel in the effect's order: motor torques in
  ``Box(-max_torque_i, max_torque_i, (n,))`` (N m) or speed set-points in ``Box(-max_speed_i,
  max_speed_i, (n,))`` (rad/s), clipped to the box as above and reported as ``info["wheels"]``
  (a ``torque_command`` beside them gets no command: zero torque). The observation then ends with
  the wheel speeds, and ``tau_k / max_torque`` in the reward is the action over its bound, wheel
  by wheel.
* **Magnetorquers**: on a scene with ``magnetorquers`` the action is the body dipole ``m_k`` (A
  m^2, body frame) the rods are commanded with (``Plant.step(dipole=...)``: their least-norm
  allocation, each rod clipped to its ``max_dipole``), in ``Box(-m_max, m_max, (3,))``, ``m_max_j =
  min(sum_i max_dipole_i |a_i . e_j|, max_command)`` (the largest body-axis component the rods
  ``a_i`` can make; a rod per axis: its ``max_dipole``), clipped to the box and reported as
  ``info["dipole"]``. The observation then ends with ``B_B`` (3, T), for a B-dot policy's
  ``dB/dt``: by default (``observed_field="truth"``) the Earth's field (the model the rods feel,
  their ``field``) at the orbit's position at ``t_k+1``, in body axes, without a sensor's errors;
  with ``observed_field="magnetometer"`` the reading of the scene's first ``magnetometer`` output
  at that sample, its errors and the scene's sensor faults in (``Plant.sensors()``: bit for bit
  the row the node and ``torquefree_bag`` publish; NaN on a sample it publishes nothing, its own
  slower ``rate`` or a ``dropout``). ``tau_k / max_torque`` in the reward is ``m_k / m_max``, axis
  by axis.
* **Which**: a scene that takes several (say ``magnetorquers`` beside a ``torque_command``) is
  commanded by the first of ``wheels``, ``dipole``, ``torque`` it takes, unless ``actuator`` (the
  constructor's) names one (:func:`_actuator`, the one place the choice is made); the others get
  no command.
* **Observation**: ``[omega_B (3, rad/s, body frame), q_NB (4, x y z w), the effects' own
  states, the wheels' speeds relative to the body (n, rad/s; none without wheels), B_B (3, T;
  a dipole's only)]``, float64 (the plant's state, bit for bit). Bounds: the quaternion's
  components in ``[-1, 1]``; when the scene's motion effects are ``torque_command`` and
  ``magnetorquers`` only, each rate within ``(|H_0| + tau_max max_steps / rate) / I_min`` (the
  momentum their torque can add in an episode, ``|H_0| <= I_max |omega_0|`` over the initial rates
  ``reset`` can draw; ``tau_max`` sums ``sqrt(3) max_torque`` of the command's box and ``sum_i
  max_dipole_i B_max`` of the rods, ``B_max`` the bound on the field's size along the orbit,
  ``Place.field_bound``) and the effects' own states unbounded (a fault of the rods: the rates
  too); ``B_B`` within ``B_max`` (the truth) or, read from the magnetometer, within the smaller
  of its ``saturation`` and, without noise, ``sum_j |C_ij| B_max + |b_i|`` and half an LSB
  (``C = I + S + M``, ``b`` its bias; unbounded with noise and no saturation, or with sensor
  faults in the scene, which change its readings); when its only motion effects are reaction
  wheels, every entry within the bounds the kinetic energy puts on it (the motors add at most
  ``sum max_torque_i max_speed_i`` watts, friction only takes energy out: ``_wheel_bounds``);
  else unbounded (Gymnasium's checker then warns about the infinite bounds: none is known for
  other effects).
  With speed set-points for actions the checker also recommends a normalised action space.
* **Reward** (:class:`DetumbleReward`, the default; ``h = 1 / rate``)::

      r_k = -h * ( |omega_B(t_k+1)|^2 / omega_ref^2 + c * |tau_k|^2 / max_torque^2 )

  ``omega_ref = |omega_0|`` of the scene (its own initial rate; 1 rad/s if that is zero), ``c =
  torque_weight`` (default 0.1), ``tau_k`` the torque held (wheels and dipoles: ``|tau_k|^2 /
  max_torque^2`` is ``sum_i (a_i / a_max_i)^2``, ``a`` the inputs held, ``a_max`` the action's
  bound). The return is
  a right Riemann sum of the quadratic cost ``-integral (|omega|^2 / omega_ref^2 + c |tau|^2 /
  max_torque^2) dt``: about the same for any rate, ``-T`` for ``T`` seconds of the initial tumble
  left alone. ``reward`` may be any callable ``reward(state, torque, next_state)`` of two
  :class:`~torquefree_ros.PlantState` and the torque held, returning a float (the vector
  environment calls it once a step on the whole batch: rows of bodies, returning ``(N,)``).
* **terminated**: ``|omega_B(t_k+1)| < omega_tol`` (default 1e-3 rad/s, 0.057 deg/s).
  **truncated**: ``k + 1 >= max_steps`` (default 1000, 100 s at 10 Hz). Stepping a truncated
  episode again raises ``RuntimeError`` (``reset()`` first); a terminated one may go on until
  ``max_steps``.
* **info**: ``t`` (s since the episode began, ``t_k+1``), ``torque`` (N m, the torque held,
  ``(3,)``; ``wheels`` or ``dipole`` instead, the inputs held), ``clipped`` (bool).
* **reset(seed=..., options=...)**: ``seed`` seeds ``np_random`` (Gymnasium's rule). The episode
  starts from the scene's own initial state, unless ``randomize`` (the constructor's, or
  ``options={"randomize": True}`` for this reset): then the initial body rate is drawn from
  ``np_random`` around the scene's, ``omega_0 = omega_scene + spread * |omega_scene| * u``, ``u``
  three draws of ``np_random.uniform(-1, 1, 3)`` (``spread`` default 0.25); the attitude and the
  effects' states are the scene's.

The vector environment
----------------------
:class:`AttitudeVectorEnv` holds N such bodies (one scene for all, or a list of scenes with the
same kinds of motion effects and the same action box), observations ``(N, 7 + m)`` (and the wheel
speeds, ``B_B``), actions ``(N, 3)`` (wheels: ``(N, n)``), with Gymnasium 1.x's **next-step
autoreset** (``metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP``): a body whose episode
ended on step ``k`` is reset on step ``k + 1`` (its action is ignored, its reward 0, terminated
and truncated False, its observation the new episode's first). Body ``i`` is bit for bit an
:class:`AttitudeEnv` of its scene reset with seed ``seed + i`` (``reset(seed=seed)``; a list gives
each its own) under the same actions, episode after episode: the same plant, the same draws.

Bodies that begin their episodes on the same step share one batched :class:`~torquefree_ros.Plant`
(a *cohort*), advanced by one compiled call a step; a plant's bodies share its clock, and a body's
samples depend on its episode's clock, so a body that resets starts a new cohort (a new plant)
rather than re-entering the old one, whose remaining bodies go on untouched. A cohort's rows whose
bodies have left are still advanced (with zero torque) until all have left, at the latest
``max_steps`` after it began. When all bodies start and end their episodes together (a fixed
episode length, no termination, or all reset at once) there is one cohort: one compiled call a step
for the whole batch; bodies that end at different steps cost one call per cohort.
"""

from __future__ import annotations

from dataclasses import replace
import math
from typing import Any, Callable

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
    from gymnasium.envs.registration import EnvSpec
    from gymnasium.utils import seeding
    from gymnasium.vector import AutoresetMode, VectorEnv
    from gymnasium.vector.utils import batch_space
except ImportError as error:  # pragma: no cover - the extra is not installed
    raise ImportError(
        "torquefree_ros.plant.gym needs gymnasium (the 'gym' extra: pip install "
        "'torquefree_ros[gym]')"
    ) from error

from .plant import _as_scene, Plant, PlantState
from ..core.body.rigid_body import RigidBody
from ..core.effects.sensors import AxisErrors, body_frame, environment_at
from ..core.faults.schedule import ACTUATOR_FAULTS
from ..core.scene.loader import Scene

__all__ = ['ENV_ID', 'AttitudeEnv', 'AttitudeVectorEnv', 'DetumbleReward']

ENV_ID = 'torquefree_ros/Attitude-v0'
OMEGA_TOL = 1e-3  # rad/s
MAX_STEPS = 1000
SPREAD = 0.25
TORQUE_WEIGHT = 0.1
#: what an action commands, in the order the default picks the first the scene takes
ACTUATORS = ('wheels', 'dipole', 'torque')
#: what a dipole's environment observes as ``B_B``: the field itself, or the scene's magnetometer
OBSERVED_FIELDS = ('truth', 'magnetometer')


class DetumbleReward:
    """
    The default reward: a quadratic cost of the body rate and the torque over the step.

    ``r_k = -h (|omega_B(t_k+1)|^2 / omega_ref^2 + c |tau_k|^2 / max_torque^2)``, ``h = dt``,
    ``c = torque_weight`` (the module's docstring). Works on one body's arrays (a float) and on a
    batch's rows (``(N,)``; ``omega_ref`` may then be ``(N,)``) with the same arithmetic, element
    by element.
    """

    def __init__(self, omega_ref, max_torque, dt: float, torque_weight: float = TORQUE_WEIGHT):
        self.omega_ref = omega_ref
        self.max_torque = max_torque
        self.dt = float(dt)
        self.torque_weight = float(torque_weight)
        self._omega_ref2 = np.multiply(omega_ref, omega_ref)
        self._torque_max2 = np.multiply(max_torque, max_torque)

    def __call__(self, state: PlantState, torque: np.ndarray, next_state: PlantState):
        w2 = _squared_norm(next_state.omega_B)
        if np.ndim(self.max_torque):  # a bound per input (wheels): sum (a_i / a_max_i)^2
            shares = np.asarray(torque) / self.max_torque
            return -self.dt * (
                w2 / self._omega_ref2 + self.torque_weight * np.sum(shares * shares, axis=-1)
            )
        t2 = _squared_norm(torque)
        return -self.dt * (w2 / self._omega_ref2 + self.torque_weight * (t2 / self._torque_max2))

    def __repr__(self) -> str:
        return (
            f'DetumbleReward(omega_ref={self.omega_ref!r}, max_torque={self.max_torque!r}, '
            f'dt={self.dt!r}, torque_weight={self.torque_weight!r})'
        )


class AttitudeEnv(gymnasium.Env):
    """
    One body of a scene that takes torque, as a Gymnasium environment (the module's docstring).

    ``scene``: a :class:`~torquefree_ros.Scene`, a scene file's path or a library scene's name,
    with a ``torque_command`` effect, commanded ``reaction_wheels`` or ``magnetorquers`` (else
    ``ValueError``); ``actuator``: ``'wheels'``, ``'dipole'`` or ``'torque'``, what the actions
    command (default: the first of these the scene takes);
    ``rate``: Hz; ``max_steps``: the episode's length (truncation); ``reward``: ``reward(state,
    torque, next_state) -> float``, default :class:`DetumbleReward`; ``omega_tol``: rad/s, the rate
    below which the episode terminates; ``randomize``, ``spread``: the initial rate drawn at every
    reset (see ``reset``); ``torque_weight``: ``c`` of the default reward; ``observed_field``:
    ``'truth'`` or ``'magnetometer'``, what a dipole's observation ends with (the module's
    docstring).
    """

    metadata = {'render_modes': []}

    def __init__(
        self,
        scene='detumble',
        rate: float = 10.0,
        max_steps: int = MAX_STEPS,
        reward: Callable | None = None,
        *,
        omega_tol: float = OMEGA_TOL,
        randomize: bool = False,
        spread: float = SPREAD,
        torque_weight: float = TORQUE_WEIGHT,
        actuator: str | None = None,
        observed_field: str = 'truth',
        render_mode: str | None = None,
    ):
        if render_mode is not None:
            raise ValueError(f'render_mode: this environment does not render, got {render_mode!r}')
        self.scene = _as_scene(scene, 'scene')
        plant = Plant(self.scene, rate)
        self.rate = plant.rate
        self.max_steps = _positive_int(max_steps, 'max_steps')
        self.omega_tol = _non_negative(omega_tol, 'omega_tol')
        self.spread = _non_negative(spread, 'spread')
        self.randomize = bool(randomize)
        self.actuator = _actuator(plant, actuator, 'scene')
        #: the topic of the magnetometer observed as B_B (None: the truth)
        self.magnetometer = _magnetometer_topic(plant, observed_field, self.actuator, 'scene')
        self.max_torque = _action_bound(self.scene, self.actuator)
        self.wheels = self.actuator == 'wheels'
        self.frame = _frame(self.scene, self.actuator)
        self.reward = (
            DetumbleReward(_omega_ref(self.scene), self.max_torque, 1.0 / self.rate, torque_weight)
            if reward is None
            else reward
        )
        if not callable(self.reward):
            text = f'reward: expected a callable reward(state, torque, next_state), got {reward!r}'
            raise ValueError(text[:300])
        self._shape = np.shape(self.max_torque) or (3,)
        self.action_space = spaces.Box(
            -self.max_torque, self.max_torque, self._shape, np.float64
        )
        self.observation_space = _observation_space(
            self.scene,
            plant.state.internal.size + plant.state.wheel_speeds.size,
            self.max_steps / self.rate,
            self.spread,
            self.actuator,
            self.magnetometer,
        )
        self._tol2 = self.omega_tol * self.omega_tol
        self._plant: Plant | None = None
        self._sensors = None  # the episode's Plant.sensors(), reading the magnetometer
        self._state: PlantState | None = None
        # what gymnasium.make would give it: a spec that makes this environment again
        # (env.spec.make())
        self.spec = EnvSpec(
            ENV_ID,
            entry_point=f'{__name__}:AttitudeEnv',
            kwargs={
                'scene': scene,
                'rate': rate,
                'max_steps': max_steps,
                'reward': reward,
                'omega_tol': omega_tol,
                'randomize': randomize,
                'spread': spread,
                'torque_weight': torque_weight,
                'actuator': actuator,
                'observed_field': observed_field,
            },
        )

    @property
    def plant(self) -> Plant | None:
        """Return the episode's plant, or ``None`` before the first ``reset``."""
        return self._plant

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """
        Start an episode at ``t = 0``; return ``(observation, {"t": 0.0})``.

        The episode starts from the scene's initial state, or with the initial body rate drawn
        from ``np_random`` when ``randomize`` (the constructor's; ``options={"randomize": bool}``
        for this reset).
        """
        super().reset(seed=seed)
        randomize = _reset_options(options, self.randomize)
        scene = _disperse(self.scene, self.spread, self.np_random) if randomize else self.scene
        self._plant = Plant(scene, self.rate)
        self._state = self._plant.state
        self._sensors = self._plant.sensors() if self.magnetometer else None
        return self._observed(), {'t': 0.0}

    def step(self, action):
        """Hold ``action`` (clipped to the box, reported in ``info``) over one sample interval."""
        plant = self._plant
        if plant is None:
            raise RuntimeError('step: call reset() before the first step')
        if plant.k >= self.max_steps:
            raise RuntimeError(
                f'step: the episode was truncated at max_steps = {self.max_steps}; call reset()'
            )
        torque, clipped = _clip(action, self._shape, self.max_torque)
        before = self._state
        self._state = plant.step(**{self.actuator: torque})
        reward = float(self.reward(before, torque, self._state))
        terminated = bool(_squared_norm(self._state.omega_B) < self._tol2)
        truncated = plant.k >= self.max_steps
        return (
            self._observed(),
            reward,
            terminated,
            truncated,
            {'t': plant.t, self.actuator: torque, 'clipped': bool(clipped)},
        )

    def _observed(self) -> np.ndarray:
        """Return the observation of the plant's sample: its state, then ``B_B`` for a dipole."""
        observed = _observation(self._state)
        if self.actuator != 'dipole':
            return observed
        if self.magnetometer:
            field_B = self._sensors.read().rows[self.magnetometer][0:3]
        else:
            field_B = _field_B(self._plant.scenes, self._plant.t, self._state.q_NB[None, :])[0]
        return np.concatenate([observed, field_B])


class AttitudeVectorEnv(VectorEnv):
    """
    N bodies in batched plants, with next-step autoreset (the module's docstring).

    ``scene``: one scene (a Scene, path or library name) for ``num_envs`` bodies, or a list of
    scenes (one body each; their motion effects of the same kinds and their action bounds equal).
    The other arguments are :class:`AttitudeEnv`'s; a ``reward`` is called once a step with the
    batch's rows and returns ``(N,)``.

    ``reset(seed=..., options=...)``: ``seed`` an int (body ``i`` gets ``seed + i``), a list of N
    seeds or ``None`` (each body keeps its generator); ``options``: ``randomize`` (bool, this
    reset) and Gymnasium's ``reset_mask`` (``(N,)`` bool: reset only these bodies).
    ``step(actions)``: ``(N, 3)`` (wheels: ``(N, n)``); ``info``: ``t``, ``torque`` (wheels:
    ``wheels``, magnetorquers: ``dipole``) and ``clipped`` per body, each with Gymnasium's
    ``_key`` mask (False for a body reset on this step).
    """

    metadata = {'autoreset_mode': AutoresetMode.NEXT_STEP, 'render_modes': []}

    def __init__(
        self,
        scene='detumble',
        num_envs: int | None = None,
        rate: float = 10.0,
        max_steps: int = MAX_STEPS,
        reward: Callable | None = None,
        *,
        omega_tol: float = OMEGA_TOL,
        randomize: bool = False,
        spread: float = SPREAD,
        torque_weight: float = TORQUE_WEIGHT,
        actuator: str | None = None,
        observed_field: str = 'truth',
        render_mode: str | None = None,
    ):
        if render_mode is not None:
            raise ValueError(f'render_mode: this environment does not render, got {render_mode!r}')
        if isinstance(scene, (list, tuple)):
            scenes = [_as_scene(s, f'scene[{i}]') for i, s in enumerate(scene)]
            if num_envs is not None and num_envs != len(scenes):
                raise ValueError(f'num_envs: {num_envs} given with {len(scenes)} scenes')
        else:
            one = _as_scene(scene, 'scene')
            scenes = [one] * _positive_int(num_envs, 'num_envs')
        if not scenes:
            raise ValueError('scene: a batch needs at least one scene')
        plant = Plant(scenes, rate)  # refuses scenes of different kinds, with the reason
        self.scenes = scenes
        self.num_envs = len(scenes)
        self.rate = plant.rate
        self.max_steps = _positive_int(max_steps, 'max_steps')
        self.omega_tol = _non_negative(omega_tol, 'omega_tol')
        self.spread = _non_negative(spread, 'spread')
        self.randomize = bool(randomize)
        where = 'scene[0]' if isinstance(scene, (list, tuple)) else 'scene'
        self.actuator = _actuator(plant, actuator, where)
        self.magnetometer = _magnetometer_topic(plant, observed_field, self.actuator, where)
        self.max_torque = _action_bound(scenes[0], self.actuator)
        self.wheels = self.actuator == 'wheels'
        limits = [_action_bound(s, self.actuator) for s in scenes]
        for index, limit in enumerate(limits):
            if not np.array_equal(limit, self.max_torque):
                what = {'wheels': 'wheel bounds', 'dipole': 'dipole bounds'}.get(
                    self.actuator, 'max_torque'
                )
                raise ValueError(
                    f"scene[{index}]: its {what} {_shown(limit)} differs from scene[0]'s "
                    f'{_shown(self.max_torque)}: the bodies of a vector environment share one '
                    'action space'
                )
        self.reward = (
            DetumbleReward(
                np.array([_omega_ref(s) for s in scenes]),
                self.max_torque,
                1.0 / self.rate,
                torque_weight,
            )
            if reward is None
            else reward
        )
        if not callable(self.reward):
            text = f'reward: expected a callable reward(state, torque, next_state), got {reward!r}'
            raise ValueError(text[:300])
        self._internal = plant.state.internal.shape[1]
        self._speeds = plant.state.wheel_speeds.shape[1]
        self._field = self.actuator == 'dipole'
        self._width = 7 + self._internal + self._speeds + (3 if self._field else 0)
        self._shape = np.shape(self.max_torque) or (3,)
        self.single_action_space = spaces.Box(
            -self.max_torque, self.max_torque, self._shape, np.float64
        )
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        bounds = [
            _observation_space(
                s,
                self._internal + self._speeds,
                self.max_steps / self.rate,
                self.spread,
                self.actuator,
                self.magnetometer,
            )
            for s in _distinct(scenes)
        ]
        self.single_observation_space = spaces.Box(
            np.min([b.low for b in bounds], axis=0),
            np.max([b.high for b in bounds], axis=0),
            dtype=np.float64,
        )
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._tol2 = self.omega_tol * self.omega_tol
        n = self.num_envs
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._cohorts: list[_Cohort] = []
        self._cohort_of: list[_Cohort | None] = [None] * n
        self._row_of = np.zeros(n, dtype=np.int64)
        self._obs = np.zeros((n, self._width))
        self._t = np.zeros(n)
        self._steps = np.zeros(n, dtype=np.int64)
        self._autoreset = np.zeros(n, dtype=bool)
        self._started = False

    @property
    def np_random(self) -> tuple:
        """Return each body's generator (as SyncVectorEnv gives its environments')."""
        for b, rng in enumerate(self._rngs):
            if rng is None:
                self._rngs[b] = seeding.np_random()[0]
        return tuple(self._rngs)

    @property
    def cohorts(self) -> int:
        """How many batched plants the bodies are in now (compiled calls a step)."""
        return len(self._cohorts)

    def reset(self, *, seed=None, options: dict[str, Any] | None = None):
        n = self.num_envs
        options = dict(options or {})
        mask = options.pop('reset_mask', None)
        randomize = _reset_options(options, self.randomize)
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(n)]
        elif isinstance(seed, (list, tuple)) and len(seed) == n:
            seeds = list(seed)
        else:
            raise ValueError(
                f'seed: expected None, an int or a list of {n} seeds, got {seed!r}'[:300]
            )
        if mask is None:
            bodies = np.arange(n)
        else:
            mask = np.asarray(mask)
            if mask.shape != (n,) or mask.dtype != np.bool_ or not mask.any():
                text = (
                    f"options['reset_mask']: expected a ({n},) bool array with a True, "
                    f'got {mask!r}'
                )
                raise ValueError(text[:300])
            if not self._started:
                raise RuntimeError('reset: the first reset resets every body (no reset_mask)')
            bodies = np.flatnonzero(mask)
        for b in bodies:
            if seeds[b] is not None or self._rngs[b] is None:
                self._rngs[b] = seeding.np_random(seeds[b])[0]
        self._begin(bodies, randomize)
        self._started = True
        return self._obs.copy(), {'t': self._t.copy(), '_t': _mask(n, bodies)}

    def step(self, actions):
        if not self._started:
            raise RuntimeError('step: call reset() before the first step')
        n = self.num_envs
        torques, clipped = _clip(actions, (n, *self._shape), self.max_torque)
        resetting = self._autoreset.copy()
        before = _split(self._obs, self._internal, self._speeds)
        for cohort in list(self._cohorts):
            self._advance(cohort, torques)
        stepped = ~resetting
        self._steps[stepped] += 1
        after = _split(self._obs, self._internal, self._speeds)
        held = np.where(stepped[:, None], torques, 0.0)
        rewards = np.where(
            stepped, np.asarray(self.reward(before, held, after), dtype=np.float64), 0.0
        )
        terminated = stepped & (_squared_norm(after.omega_B) < self._tol2)
        truncated = stepped & (self._steps >= self.max_steps)
        # next-step autoreset: those whose episode ended on the last step begin again
        if resetting.any():
            self._begin(np.flatnonzero(resetting), self.randomize)
        self._autoreset = terminated | truncated
        key = self.actuator
        info = {
            't': self._t.copy(),
            '_t': np.ones(n, dtype=bool),
            key: held,
            f'_{key}': stepped.copy(),
            'clipped': clipped & stepped,
            '_clipped': stepped.copy(),
        }
        return self._obs.copy(), rewards, terminated, truncated, info

    # -- internals -------------------------------------------------------------------------------
    def _begin(self, bodies: np.ndarray, randomize: bool) -> None:
        """
        Begin new episodes for ``bodies``.

        They leave their cohorts and form a new one, at its sample 0.
        """
        scenes = [
            _disperse(self.scenes[b], self.spread, self._rngs[b]) if randomize else self.scenes[b]
            for b in bodies
        ]
        cohort = _Cohort(Plant(scenes, self.rate), bodies, self._field, self.magnetometer)
        for row, b in enumerate(bodies):
            old = self._cohort_of[b]
            if old is not None:
                old.alive[self._row_of[b]] = False
            self._cohort_of[b], self._row_of[b] = cohort, row
        self._cohorts = [c for c in self._cohorts if c.alive.any()] + [cohort]
        self._obs[bodies] = cohort.rows(cohort.plant.state)
        self._t[bodies] = 0.0
        self._steps[bodies] = 0
        self._autoreset[bodies] = False

    def _advance(self, cohort: _Cohort, torques: np.ndarray) -> None:
        alive = cohort.alive & ~self._autoreset[cohort.bodies]
        if not alive.any():
            return
        held = np.zeros((cohort.bodies.size, *self._shape))
        held[alive] = torques[cohort.bodies[alive]]
        rows = cohort.rows(cohort.plant.step(**{self.actuator: held}))
        self._obs[cohort.bodies[alive]] = rows[alive]
        self._t[cohort.bodies[alive]] = cohort.plant.t


class _Cohort:
    """
    Bodies that began their episodes on the same step, in one batched plant.

    Row ``r`` is body ``bodies[r]`` while ``alive[r]``; ``field``: the rows end with ``B_B``, the
    truth or, with ``magnetometer`` (a topic), that output's reading.
    """

    def __init__(
        self, plant: Plant, bodies: np.ndarray, field: bool = False, magnetometer=None
    ):
        self.plant = plant
        self.bodies = np.asarray(bodies, dtype=np.int64)
        self.alive = np.ones(self.bodies.size, dtype=bool)
        self.field = field
        self.magnetometer = magnetometer
        self.sensors = plant.sensors() if magnetometer else None

    def rows(self, state: PlantState) -> np.ndarray:
        """Return the observations of the plant's sample ``state``, a row per body."""
        columns = [state.omega_B, state.q_NB, state.internal, state.wheel_speeds]
        if self.magnetometer:
            columns.append(self.sensors.read().rows[self.magnetometer][:, 0:3])
        elif self.field:
            columns.append(_field_B(self.plant.scenes, self.plant.t, state.q_NB))
        return np.concatenate(columns, axis=1)


# -- helpers -------------------------------------------------------------------------------------
def _squared_norm(v):
    """
    Return ``v_x^2 + v_y^2 + v_z^2`` over the last axis.

    The same order of operations for one vector and for rows.
    """
    v = np.asarray(v)
    return v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1] + v[..., 2] * v[..., 2]


def _observation(state: PlantState) -> np.ndarray:
    return np.concatenate([state.omega_B, state.q_NB, state.internal, state.wheel_speeds])


def _split(rows: np.ndarray, internal: int, speeds: int) -> PlantState:
    end = 7 + internal
    return PlantState(
        rows[:, :3].copy(),
        rows[:, 3:7].copy(),
        rows[:, 7:end].copy(),
        rows[:, end: end + speeds].copy(),
    )


def _field_B(scenes: list, t: float, q_NB: np.ndarray) -> np.ndarray:
    """
    Return the Earth's field in each body's frame at scene time ``t``, T, a row per body.

    ``B_B = R(q_NB)^T B_N(r(t), t)``: the field model the scene's ``magnetorquers`` feel (their
    ``field``) at the orbit's position at ``t``, through the magnetometer's own two steps
    (``sensors.environment_at``: bodies on one orbit share one evaluation; ``sensors.body_frame``).
    The truth, without a sensor's errors.
    """
    times = np.array([float(t)])
    field_N = np.vstack([
        environment_at(scene.orbit, times, _rods(scene).values['field']) for scene in scenes
    ])
    return body_frame(np.asarray(q_NB, dtype=float).reshape(-1, 4), field_N)


def _mask(n: int, bodies: np.ndarray) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    mask[bodies] = True
    return mask


def _clip(action, shape: tuple, max_torque) -> tuple[np.ndarray, np.ndarray]:
    """
    Return the action clipped to ``[-max_torque, max_torque]``, and whether each body's was.

    ``max_torque``: a number, or one per component (wheels).

    The action as float64 of ``shape``, clipped to ``[-max_torque, max_torque]``; and whether
    each body's was clipped. Not numbers, the wrong shape or not finite: ``ValueError``.
    """
    try:
        values = np.array(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f'action: expected numbers of shape {shape}, got {action!r}'[:300]
        ) from None
    if values.shape != shape:
        raise ValueError(f'action: expected shape {shape}, got {values.shape}')
    finite = np.isfinite(values)
    if not finite.all():
        where = np.argwhere(~finite)[0]
        body = f' (body {where[0]})' if len(shape) == 2 else ''
        raise ValueError(f'action: not finite{body}: {values[tuple(where[:-1])].tolist()}')
    clipped = np.clip(values, -max_torque, max_torque)
    return clipped, np.any(clipped != values, axis=-1)


def _command_effect(scene: Scene):
    commands = [e for e in scene.effects if e.name == 'torque_command']
    return commands[0] if commands else None


def _actuator(plant: Plant, wanted, where: str) -> str:
    """
    Return what the actions command: ``wanted``, or the first of :data:`ACTUATORS` the scene takes.

    The one place the environments choose between a body torque (``torque_command``), the
    commanded ``reaction_wheels``' inputs and the ``magnetorquers``' dipole; ``wanted`` (the
    constructor's ``actuator``) must be one the scene takes.
    """
    taken = [
        name
        for name, takes in zip(
            ACTUATORS, (plant.takes_wheels, plant.takes_dipole, plant.takes_torque)
        )
        if takes
    ]
    source = plant.scenes[0].source
    if wanted is None:
        if not taken:
            raise ValueError(
                f'{where}: {source} takes no torque (it names no torque_command effect, no '
                'commanded reaction_wheels and no magnetorquers); an attitude environment needs '
                'one'
            )
        return taken[0]
    if not isinstance(wanted, str) or wanted not in ACTUATORS:
        known = ', '.join(map(repr, ACTUATORS))
        text = f'actuator: expected one of {known} or None, got {wanted!r}'
        raise ValueError(text[:300])
    if wanted not in taken:
        raise ValueError(
            f"actuator: {source} takes no {wanted} (it takes {', '.join(taken) or 'no command'})"
        )
    return wanted


def _magnetometer_topic(plant: Plant, observed_field, actuator: str, where: str):
    """
    Return the topic of the magnetometer observed as ``B_B``, or None to observe the truth.

    ``observed_field`` (the constructor's): ``'truth'``, or ``'magnetometer'``: the first
    ``magnetometer`` output of the scenes (a batch's must have the same outputs: refused here,
    with the reason, rather than at the first reset), for a dipole's observation only.
    """
    if not isinstance(observed_field, str) or observed_field not in OBSERVED_FIELDS:
        known = ', '.join(map(repr, OBSERVED_FIELDS))
        raise ValueError(f'observed_field: expected one of {known}, got {observed_field!r}'[:300])
    if observed_field == 'truth':
        return None
    if actuator != 'dipole':
        raise ValueError(
            'observed_field: the field is observed with a dipole action only, the actions '
            f'command {actuator}'
        )
    magnetometers = [o for o in plant.scenes[0].outputs if o.name == 'magnetometer']
    if not magnetometers:
        raise ValueError(
            f'observed_field: {where} ({plant.scenes[0].source}) has no magnetometer output to '
            'read'
        )
    plant.sensors()  # a batch's outputs that differ: refused now, with the reason
    return magnetometers[0].topic


def _action_bound(scene: Scene, actuator: str):
    """
    Return the action's bound: ``max_torque`` of the torque, or one per input (an array).

    Wheels: their ``max_torque`` (mode ``torque``) or ``max_speed`` (mode ``speed``), wheel by
    wheel. Dipole: per body axis ``j``, the largest component the rods can make, ``sum_i
    max_dipole_i |a_i . e_j|`` (the support of their dipoles' zonotope along ``e_j``; a rod per
    axis: its ``max_dipole``), and at most ``max_command`` (beyond which the plant refuses).
    """
    if actuator == 'wheels':
        (wheels,) = [
            e for e in scene.effects if e.name == 'reaction_wheels' and e.commanded
        ]
        key = 'max_speed' if wheels.mode == 'speed' else 'max_torque'
        return np.array([float(wheel[key]) for wheel in wheels.values['wheels']])
    if actuator == 'dipole':
        rods = _rods(scene)
        reach = np.abs(rods.axes).T @ rods.max_dipoles
        return np.minimum(reach, rods.values['max_command'])
    return float(_command_effect(scene).values['max_torque'])


def _rods(scene: Scene):
    (rods,) = [e for e in scene.effects if e.name == 'magnetorquers']
    return rods


def _frame(scene: Scene, actuator: str) -> str:
    """Return the frame of the actions: ``wheels``, ``body`` (a dipole) or the torque's frame."""
    if actuator == 'wheels':
        return 'wheels'
    if actuator == 'dipole':
        return 'body'
    return 'inertial' if _command_effect(scene).inertial else 'body'


def _shown(bound) -> str:
    if np.ndim(bound):
        return '[' + ', '.join(f'{x:g}' for x in bound) + ']'
    return f'{bound:g} N m'


def _omega_ref(scene: Scene) -> float:
    norm = float(np.linalg.norm(np.asarray(scene.angular_velocity, dtype=float)))
    return norm if norm > 0.0 else 1.0


def _disperse(scene: Scene, spread: float, rng: np.random.Generator) -> Scene:
    """
    Return the scene with its initial body rate drawn around its own.

    ``omega + spread |omega| u``, ``u`` from ``rng.uniform(-1, 1, 3)``.
    """
    omega = np.asarray(scene.angular_velocity, dtype=float)
    drawn = omega + spread * float(np.linalg.norm(omega)) * rng.uniform(-1.0, 1.0, 3)
    return replace(scene, angular_velocity=tuple(float(x) for x in drawn))


def _observation_space(
    scene: Scene,
    internal: int,
    duration: float,
    spread: float,
    actuator: str = 'torque',
    magnetometer: str | None = None,
) -> spaces.Box:
    """
    Return the observation space with the module's bounds.

    The rates within what the torques can add to the initial momentum in ``duration`` when
    ``torque_command`` and ``magnetorquers`` are the only motion effects (|omega| <= |H| /
    I_min); every entry within :func:`_wheel_bounds` when reaction wheels are the only ones; else
    unbounded. A dipole's environment observes ``B_B`` last (three more entries,
    :func:`_field_bounds`).
    """
    space = _state_space(scene, internal, duration, spread)
    if actuator != 'dipole':
        return space
    high = np.concatenate([space.high, _field_bounds(scene, magnetometer)])
    return spaces.Box(-high, high, dtype=np.float64)


def _field_bounds(scene: Scene, magnetometer: str | None) -> np.ndarray:
    """
    Return the bounds of the observed ``B_B``'s components, T.

    The truth: ``B_max`` of the rods' field model on the orbit (``Place.field_bound``), with a
    margin of 1e-6 for rounding. The magnetometer (``magnetometer``, its topic): its
    ``saturation`` clips the reading; without noise ``|B_meas,i| <= sum_j |C_ij| B_max +
    |b_i|`` (``C = I + S + M``, ``b`` the bias) and half an LSB with quantization; the smaller of
    the two. Unbounded with noise and no saturation (a normal's tail), or with sensor faults in
    the scene (they change the readings).
    """
    b_max = scene.orbit.field_bound(_rods(scene).values['field'])
    if magnetometer is None:
        return np.full(3, b_max * (1.0 + 1e-6))
    (sensor,) = [o for o in scene.outputs if o.name == 'magnetometer' and o.topic == magnetometer]
    if any(fault.kind not in ACTUATOR_FAULTS for fault in scene.faults):
        return np.full(3, np.inf)
    values = sensor.values
    errors = AxisErrors(values, 'T')
    high = np.full(3, np.inf)
    if values['noise'] == 0.0:
        matrix = np.eye(3) if errors.matrix is None else errors.matrix
        high = np.abs(matrix).sum(axis=1) * b_max + np.abs(np.asarray(values['bias'], float))
        if errors.lsb is not None:
            high = high + 0.5 * errors.lsb
    if errors.limit is not None:
        high = np.minimum(high, errors.limit)
    return high * (1.0 + 1e-6)


def _state_space(scene: Scene, internal: int, duration: float, spread: float) -> spaces.Box:
    """Return the bounds of the plant's state in the observation (:func:`_observation_space`)."""
    omega0 = float(np.linalg.norm(np.asarray(scene.angular_velocity, dtype=float)))
    omega0 *= 1.0 + math.sqrt(3.0) * spread  # the largest rate reset can draw
    if scene.effects and all(e.name == 'reaction_wheels' for e in scene.effects):
        bounds = _wheel_bounds(scene, omega0, duration)
        high = np.concatenate([bounds[:3], np.ones(4), bounds[3:]])
        return spaces.Box(-high, high, dtype=np.float64)
    rate = math.inf
    if all(e.name in ('torque_command', 'magnetorquers') for e in scene.effects):
        moments = RigidBody.from_inertia(scene.inertia).moments
        momentum = float(moments.max()) * omega0 + _torque_bound(scene) * duration
        rate = momentum / float(moments.min()) * (1.0 + 1e-6)
    high = np.concatenate([np.full(3, rate), np.ones(4), np.full(internal, np.inf)])
    return spaces.Box(-high, high, dtype=np.float64)


def _torque_bound(scene: Scene) -> float:
    """
    Return a bound on ``|tau|`` (N m) of the scene's ``torque_command`` and ``magnetorquers``.

    The command's box: ``sqrt(3) max_torque``; the rods: ``|m x B| <= sum_i max_dipole_i B_max``
    (each rod's dipole within its ``max_dipole`` along its unit axis, ``B_max`` the field's bound
    along the orbit, ``Place.field_bound``, of the model the rods feel); none (inf) with a fault of
    the rods.
    """
    if any(ACTUATOR_FAULTS.get(fault.kind) == 'magnetorquers' for fault in scene.faults):
        return math.inf  # a stuck rod's value, the dipole's noise: not within max_dipole
    bound = 0.0
    for effect in scene.effects:
        if effect.name == 'torque_command':
            bound += math.sqrt(3.0) * float(effect.values['max_torque'])
        else:
            b_max = scene.orbit.field_bound(effect.values['field'])
            bound += float(np.sum(effect.max_dipoles)) * b_max
    return bound


def _wheel_bounds(scene: Scene, omega0: float, duration: float) -> np.ndarray:
    """
    Return bounds of the rates, the wheels' states and speeds over an episode of ``duration``.

    The kinetic energy ``T = w . I_s w / 2 + sum h_i^2 / (2 Js_i)`` changes at ``dT/dt = sum
    (u_i - f_i) Omega_i``: friction only takes energy out (``f`` has the sign of ``Omega``), and
    a motor puts it in only while speeding its wheel up below ``max_speed`` (the speed limit), at
    most ``max_torque max_speed``. So ``T <= T_0 + duration sum max_torque_i max_speed_i``, with
    ``T_0`` at most the initial state's for rates up to ``omega0``; then ``|w| <= sqrt(2 T /
    min eig I_s)``, ``|h_i| <= sqrt(2 Js_i T)``, ``|Omega_i| <= |h_i| / Js_i + |w|`` and the
    angle ``|theta_i| <= duration max |Omega_i|``. Returned in the observation's order but for
    the attitude: the rates (3), each effect's ``(h_i, theta_i)`` pairs, the speeds; with a margin
    of 1e-6 of each for rounding and the integrator's error.
    """
    body = RigidBody.from_inertia(scene.inertia)
    spin = sum(effect.spin_inertia_B() for effect in scene.effects)
    remaining = np.linalg.eigvalsh(body.tensor - spin)
    energy = 0.5 * float(remaining.max()) * omega0 * omega0
    power = 0.0
    for effect in scene.effects:
        for row, wheel in zip(effect.rows, effect.values['wheels']):
            Js = row[3]
            energy += 0.5 * Js * (abs(wheel['speed']) + omega0) ** 2
            power += row[4] * row[5]
    energy += power * duration
    rate = math.sqrt(2.0 * energy / float(remaining.min()))
    states, speeds = [], []
    for effect in scene.effects:
        for Js in effect.spin_inertias.tolist():
            speed = math.sqrt(2.0 * energy / Js) + rate
            states += [math.sqrt(2.0 * energy * Js), duration * speed]
            speeds.append(speed)
    return np.array([rate] * 3 + states + speeds) * (1.0 + 1e-6)


def _distinct(scenes: list) -> list:
    seen, out = set(), []
    for s in scenes:
        if id(s) not in seen:
            seen.add(id(s))
            out.append(s)
    return out


def _reset_options(options, default: bool) -> bool:
    options = {} if options is None else dict(options)
    randomize = options.pop('randomize', default)
    if options:
        raise ValueError(f"options: unknown {sorted(options)} (known: 'randomize')")
    if not isinstance(randomize, (bool, np.bool_)):
        raise ValueError(f"options['randomize']: expected a bool, got {randomize!r}")
    return bool(randomize)


def _positive_int(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f'{name}: expected a positive integer, got {value!r}')
    return int(value)


def _non_negative(value, name: str) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float, np.integer, np.floating))
        or not (math.isfinite(value) and value >= 0)
    ):
        raise ValueError(f'{name}: expected a finite non-negative number, got {value!r}')
    return float(value)


if ENV_ID not in gymnasium.registry:
    gymnasium.register(
        ENV_ID,
        entry_point=f'{__name__}:AttitudeEnv',
        vector_entry_point=f'{__name__}:AttitudeVectorEnv',
    )
