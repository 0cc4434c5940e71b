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
One interface for every propagator (after scipy's ``OdeSolver`` family).

Construct from a body, an initial state and the scene's motion effects, then evaluate
``(omega_B, q_NB)`` at any sorted array of times since that state.
"""

from __future__ import annotations

import abc
import math
from typing import ClassVar

import numpy as np

from .dynamics import Dynamics
from ..body.rigid_body import RigidBody
from ..checks.validation import finite_vector, initial_samples, sample_times, unit_quaternion
from ..numerics.steps import MAX_STEPS_PER_SAMPLE


class Propagator(abc.ABC):
    """
    Base class. Subclasses set ``name`` and ``exact`` and implement :meth:`_evaluate`.

    ``__call__(times)`` returns ``omega_B`` of shape ``(N, 3)`` (rad/s, body frame) and ``q_NB`` of
    shape ``(N, 4)`` (``x, y, z, w``) for the sorted, non-negative ``times`` (s); :meth:`states`
    adds the effects' own states (shape ``(N, state_size)``, empty for most scenes).

    ``effects``: the scene's motion effects (:class:`~torquefree_ros.core.effects.MotionEffect`);
    only propagators with ``supports_effects`` take any.
    """

    name: ClassVar[str]
    exact: ClassVar[bool] = False
    #: integrator steps allowed from one requested time to the next (None: unbounded, if a caller
    #: really means it). No sample can then hold the node's loop (a reset, a shutdown) or an
    #: offline tool for long; over it, the evaluation raises :class:`StepBudgetExceeded` with the
    #: reason.
    max_steps_per_sample: int | None = MAX_STEPS_PER_SAMPLE
    supports_effects: ClassVar[bool] = True
    #: option name -> default; anything else given to the constructor is an error
    options: ClassVar[dict] = {}

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        self.body = RigidBody.from_inertia(body)
        self.omega0_B = finite_vector(angular_velocity, 'angular_velocity', (3,))
        self.q0_NB = unit_quaternion(orientation, 'orientation')
        problem = unrepresentable_state(self.body, self.omega0_B)
        if problem is not None:
            raise ValueError(f'angular_velocity: {problem}')
        unknown = sorted(set(options) - set(self.options))
        if unknown:
            known = ', '.join(sorted(self.options)) or 'none'
            raise ValueError(
                f"{unknown[0]}: not an option of propagator '{self.name}' (options: {known})"
            )
        effects = tuple(effects)
        if effects and not self.supports_effects:
            names = ', '.join(effect.name for effect in effects)
            raise ValueError(
                f"propagator: '{self.name}' is the exact torque-free solution; "
                f"the scene's effects ({names}) need a numerical propagator ('auto' picks one)"
            )
        self.settings = {**self.options, **options}
        # Without effects (the exact solution's only case) the equations of motion are built when
        # first asked for: a propagator is built on every reset and for every body of a batch.
        self._dynamics = (
            Dynamics(self.body, [effect.bound(self.body.tensor) for effect in effects])
            if effects
            else None
        )
        self.x0 = self._dynamics.initial_state(self.omega0_B) if effects else _NO_EFFECT_STATE
        if effects:
            overflowing = self._dynamics.overflowing_effect(self.omega0_B, self.q0_NB, self.x0)
            if overflowing is not None:
                raise ValueError(
                    f'effects: {overflowing_message(self._dynamics.effects[overflowing])}'
                )

    @property
    def dynamics(self) -> Dynamics:
        if self._dynamics is None:
            self._dynamics = Dynamics(self.body)
        return self._dynamics

    @property
    def effects(self) -> tuple:
        return self.dynamics.effects

    @property
    def conserved(self) -> frozenset:
        """
        Return the invariants (``energy``, ``momentum``) the motion keeps.

        A numerical propagator's drift in them is its error; the others change by physics.
        """
        return self.dynamics.conserved

    def __call__(self, times):
        omega, q, _ = self.states(times)
        return omega, q

    def states(self, times):
        """``(omega_B, q_NB, x)`` at ``times``; ``x`` holds the effects' own states."""
        times = sample_times(times)
        omega, q, x = self._evaluate(times)
        zeros = initial_samples(times)
        if zeros:
            omega[:zeros] = self.omega0_B
            q[:zeros] = self.q0_NB
            x[:zeros] = self.x0
        return omega, q, x

    def stop_at_samples(self, rate: float) -> None:
        """
        Make every sample time ``k / rate`` a breakpoint, and start over from the initial state.

        For a scene whose torque is held from sample to sample: a controller's command.
        """
        self.dynamics.sample_rate = float(rate)
        self._restart()

    def _restart(self) -> None:
        """Forget any progress: the next evaluation starts from the initial state."""

    def momentum_B(self, omega_B, x) -> np.ndarray:
        """Total angular momentum, body + effects, body frame."""
        return self.dynamics.momentum_B(np.asarray(omega_B, float), np.asarray(x, float))

    def energy(self, omega_B, x) -> np.ndarray:
        """Total kinetic energy, body + effects."""
        return self.dynamics.energy(np.asarray(omega_B, float), np.asarray(x, float))

    @abc.abstractmethod
    def _evaluate(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def describe(self) -> str:
        settings = ', '.join(f'{k}={v:g}' for k, v in self.settings.items())
        return f'{self.name}({settings})' if settings else self.name


def overflowing_message(effect) -> str:
    return (
        f"{effect.describe()}: its torque or its own state's rate overflows float64 "
        'at the initial state (a parameter far outside any physical scale)'
    )


_NO_EFFECT_STATE = np.empty(0)
_NO_EFFECT_STATE.flags.writeable = False


def unrepresentable_state(body: RigidBody, omega_B) -> str | None:
    """
    Say why a body at ``omega_B`` overflows float64, or return None when it does not.

    The solvers form products like ``I_max * |H|^2``; they must stay finite in float64. Every
    propagator built runs this, and scenes run it when they load (a field path before the reason).
    """
    # plain floats: three numbers, checked on every propagator built; a product that overflows is
    # inf, never an OverflowError (only ** and math functions raise)
    w = [float(x) for x in omega_B]
    h = [row[0] * w[0] + row[1] * w[1] + row[2] * w[2] for row in body.tensor.tolist()]
    largest = max(body.moments.tolist())
    scale = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]) * largest * largest
    if math.isfinite(scale):
        return None
    return (
        f'the state {w} with moments {body.moments.tolist()} '
        'overflows float64 (|H|^2 * I_max^2 is not finite)'
    )


#: name -> class; filled by the modules that define propagators
PROPAGATORS: dict[str, type[Propagator]] = {}


def register(cls: type[Propagator]) -> type[Propagator]:
    PROPAGATORS[cls.name] = cls
    return cls


def propagator_class(name: str) -> type[Propagator]:
    try:
        return PROPAGATORS[name]
    except KeyError:
        known = ', '.join(['auto', *sorted(PROPAGATORS)])
        raise ValueError(f'propagator: unknown propagator {name!r} (known: {known})') from None
