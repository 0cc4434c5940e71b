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
One interface for every effect, one registry.

An effect is named in a scene as ``- NAME: {parameters}``. Two kinds share the registry:

* a :class:`MotionEffect` changes the motion: it adds a body-frame torque to Euler's equations
  ``I w' + w x I w = sum(torque_B)`` and may carry a state of its own (a damper's rate) with its
  own derivative. ``uses_attitude`` says whether it needs ``q`` (then integrators must supply stage
  attitudes), ``conserves`` which invariants survive it, ``breakpoints`` where its torque jumps.
  An effect whose state carries the momentum of a part of the body's inertia (reaction wheels'
  absolute axial momenta) returns that part from ``spin_inertia_B``: Euler's equations are then
  integrated with the inertia less it.
* an :class:`OutputEffect` only derives a topic from the samples (an IMU, Euler angles); it never
  changes the motion, so a scene with outputs alone keeps the exact propagator.

Parameters are declared as :class:`~torquefree_ros.core.checks.schema.Param` and checked before the
class is built, so every error carries the field path (``effects[1].torque``). An effect that reads
the environment (``needs_orbit``: the orbit's position, the magnetic field, the Sun) is
:meth:`Effect.placed` in the scene's orbit when the scene loads (``core.environment.place``).
"""

from __future__ import annotations

import abc
import copy
import math
from typing import ClassVar

import numpy as np

from ..checks.schema import child, FieldError, fields, number, one_key, Param

#: effect name -> class; filled by the modules that define effects
EFFECTS: dict[str, type['Effect']] = {}
ENERGY, MOMENTUM = 'energy', 'momentum'


class Effect(abc.ABC):
    name: ClassVar[str]
    summary: ClassVar[str]  # one line for the catalogue
    parameters: ClassVar[dict[str, Param]] = {}
    changes_motion: ClassVar[bool]

    def __init__(self, **values):
        self.values = values

    @classmethod
    def from_parameters(cls, values: dict, path: str) -> 'Effect':
        """Build from checked ``values``; cross-field rules raise ``FieldError`` under ``path``."""
        return cls(**values)

    def __eq__(self, other) -> bool:
        """
        Tell whether ``other`` is of the same kind with the same parameters.

        Scenes loaded twice compare equal.
        """
        if type(other) is not type(self):
            return NotImplemented
        return self.values.keys() == other.values.keys() and all(
            np.array_equal(value, other.values[key])
            if isinstance(value, np.ndarray)
            else value == other.values[key]
            for key, value in self.values.items()
        )

    def __hash__(self) -> int:
        return hash((type(self), tuple(self.values)))

    #: the hold of the commands this effect takes, once bound to a propagator (None: it takes none)
    hold = None

    @property
    def takes_commands(self) -> bool:
        """Whether this effect, bound to a propagator, takes commands: it has a hold of its own."""
        return self.hold is not None

    #: whether it is set to take commands on its ``topic`` (bound, it then has a hold of its own)
    commanded: ClassVar[bool] = False
    #: whether commands on its ``topic`` are refused and counted: it takes none (held wheels)
    refuses_commands: ClassVar[bool] = False

    #: the scene's place (``core.environment.place.Place``: its orbit and start) once placed there
    place = None
    #: whether it reads the environment (an orbit's position, the magnetic field, the Sun)
    needs_orbit: ClassVar[bool] = False
    #: what its kernel reads of the environment held per window, placed: indices of
    #: ``core.environment.place.QUANTITIES`` (the position, a field model's field)
    environment_quantities: tuple = ()

    def placed(self, place, path: str) -> 'Effect':
        """
        Return this effect in the scene's ``place`` (None: a scene without an ``orbit:``).

        An effect that reads the environment gets a copy that keeps ``place``; without one it is
        refused with a ``FieldError`` at ``path``. The others are returned as they are.
        """
        if not self.needs_orbit:
            return self
        if place is None:
            raise FieldError(
                path,
                "needs the scene's orbit: add an 'orbit:' section (Keplerian elements at an "
                "'epoch', or 'tle: [line1, line2]')",
            )
        placed = copy.copy(self)
        placed.place = place
        return placed

    def describe(self) -> str:
        shown = ', '.join(
            f'{key}={_short(value)}' for key, value in self.values.items() if value is not None
        )
        return f'{self.name}({shown})'


class MotionEffect(Effect):
    changes_motion = True
    uses_attitude: ClassVar[bool] = False
    #: the torque changes only at sample times (a command held from sample to sample)
    holds_per_sample: ClassVar[bool] = False
    state_size: ClassVar[int] = 0
    #: inputs held per piece in a slot of its own in the compiled ``held`` (a stateless effect's
    #: commanded values: magnetorquers' applied dipole), given by :meth:`held_slot`
    held_slot_size: ClassVar[int] = 0
    conserves: ClassVar[frozenset] = frozenset()
    #: its torque's compiled form: a code of ``compiled/motion_kernels.py`` (whose section
    #: there reads :meth:`kernel_parameters`), or None for a torque held constant on each smooth
    #: piece, which the compiled integrators take from :meth:`held_torque` where the piece starts
    kernel_code: ClassVar[int | None] = None

    def bound(self, tensor: np.ndarray) -> 'MotionEffect':
        """
        Return this effect for a body of inertia ``tensor`` (body frame).

        A copy when it needs it.
        """
        return self

    def initial_state(self, omega0_B: np.ndarray) -> np.ndarray:
        return np.empty(0)

    @abc.abstractmethod
    def torque_B(
        self,
        t: float,
        omega_B: np.ndarray,
        q_NB: np.ndarray,
        state: np.ndarray,
        segment_start: float,
    ) -> np.ndarray:
        """
        Return the body-frame torque on the body.

        ``segment_start``: where the smooth piece being integrated begins (a breakpoint or a step
        start); piecewise quantities are those of the piece starting there, so a stage evaluated
        exactly at the next breakpoint still sees this piece.
        """

    def state_rate(
        self,
        t: float,
        omega_B: np.ndarray,
        q_NB: np.ndarray,
        state: np.ndarray,
        segment_start: float,
    ) -> np.ndarray:
        """Return the rate of the effect's own state (``segment_start`` as in :meth:`torque_B`)."""
        return np.empty(0)

    def breakpoints(self) -> tuple[float, ...]:
        return ()

    def kernel_parameters(self) -> tuple[float, ...]:
        """Return the numbers its kernel reads, in order (bound: after :meth:`bound`)."""
        return ()

    def held_torque(self, segment_start: float) -> tuple[np.ndarray, bool]:
        """
        Return the torque held on the piece starting at ``segment_start``, and its frame.

        For an effect without a kernel: the torque it holds, and whether it is in the inertial
        frame (else the body frame).
        """
        raise NotImplementedError(f'{self.name}: neither a kernel code nor a held torque')

    def held_inputs(self, segment_start: float) -> np.ndarray | None:
        """
        Return the numbers its kernel reads from ``held`` on the piece from ``segment_start``.

        One per component of the effect's own state (a wheel's motor torque), or None (none): the
        compiled path reads them at ``held[6 + s]``, ``s`` the state component's index in the
        effects' flat state, so an input held per piece (a schedule now, a command hold later)
        reaches a kernel without a new model.
        """
        return None

    def held_slot(self, segment_start: float) -> np.ndarray | None:
        """Return the :attr:`held_slot_size` inputs held on the piece from ``segment_start``."""
        return None

    def spin_inertia_B(self) -> np.ndarray:
        """
        Return the inertia ``J`` (3 x 3, body frame) whose momentum the effect's own state carries.

        Reaction wheels: ``sum Js g g^T``; the scene's inertia ``I`` includes them locked. Euler's
        equations are then integrated with ``I - J`` (the momentum ``J w`` lives in the effect's
        absolute state; Schaub & Junkins, *Analytical Mechanics of Space Systems*, ch. 4, momentum
        exchange devices), and the invariants count ``I w - J w + momentum_B(state)``. Zero for
        most effects.
        """
        return np.zeros((3, 3))

    def monitor(self, rate: float):
        """
        Return what /diagnostics reports of this effect in a run at ``rate`` Hz, or None.

        An object with ``update(times, omega_B, state)`` (each block of samples, in order, the
        effect's part of the states) and ``diagnostics() -> (values, warning)``: reaction wheels'
        speeds, time limited and stored momentum.
        """
        return None

    def momentum_B(self, state: np.ndarray) -> np.ndarray:
        """
        Return the angular momentum the effect carries itself (a wheel, a damper), body frame.

        Broadcasts over leading axes of ``state``.
        """
        return np.zeros(state.shape[:-1] + (3,))

    def energy(self, state: np.ndarray) -> np.ndarray:
        return np.zeros(state.shape[:-1])


class OutputEffect(Effect):
    """
    Derives one topic from the samples.

    ``topic``, ``message_type``; ``frame`` is ``body`` or ``inertial`` (the frame id the node uses
    for it). :meth:`stream` starts the output for a run. Every output may set its own ``rate``
    (``RATE``): it then goes out on every n-th sample.
    """

    changes_motion = False
    message_type: ClassVar[str]
    frame: ClassVar[str]
    #: the message's form: "doubles" (a Header, then the row's float64s), "transform" (parent
    #: ``frame``, child the body frame), "odometry" (nav_msgs/Odometry, parent ``frame``, child the
    #: body frame) or "markers" (a MarkerArray drawn from the row)
    layout: ClassVar[str] = 'doubles'
    RATE = Param(
        number(positive=True, unit='Hz'), None, 'its own rate; must divide the sample rate'
    )

    @property
    def topic(self) -> str:
        return self.values.get('topic') or self.name

    def every(self, rate: float, rate_name: str = 'rate') -> int:
        """
        Return ``n``: the output goes out on samples ``k = 0, n, 2n, ...`` of a run at ``rate`` Hz.

        ``n`` is 1 without a rate of its own; a rate that does not divide ``rate`` is a
        ``ValueError``.
        """
        own = self.values.get('rate')
        if own is None:
            return 1
        ratio = rate / own
        n = round(ratio)
        if n < 1 or abs(ratio - n) > 1e-9 * ratio:
            raise ValueError(
                f'{self.name}.rate: {own:g} Hz must divide {rate_name} {rate:g} Hz into a whole '
                f'number of samples, got {ratio:.6g}'
            )
        return n

    def for_run(self, propagator) -> 'OutputEffect':
        """
        Return this output for a run of ``propagator``: itself, or a copy knowing more of the run.

        ``wheel_states`` learns the wheels' names, which its messages carry.
        """
        return self

    @property
    def layout_options(self) -> dict:
        """Return what its layout's encoder takes beyond the rows (keywords; ``names``)."""
        return {}

    @abc.abstractmethod
    def stream(self, rate: float, propagator) -> 'OutputStream':
        """
        Return the output of one run at ``rate`` Hz of ``propagator``.

        The propagator gives its body, initial state and invariants.
        """


class OutputStream(abc.ABC):
    """
    One run's output: a row of float64 per sample.

    ``rows(first, times, omega_B, q_NB, internal)`` gives them (``internal``: the effects' own
    states), the message's numbers in the order its layout reads them. Rows depend only on the
    sample index and the scene, never on how samples are cut into blocks.
    """

    @abc.abstractmethod
    def rows(
        self,
        first: int,
        times: np.ndarray,
        omega_B: np.ndarray,
        q_NB: np.ndarray,
        internal: np.ndarray,
    ) -> np.ndarray: ...


def register(cls):
    EFFECTS[cls.name] = cls
    return cls


def parse_effect(entry, path: str) -> Effect:
    name, parameters = one_key(entry, path, EFFECTS, 'effect')
    cls = EFFECTS[name]
    where = child(path, name)
    values = fields(parameters, where, cls.parameters)
    return cls.from_parameters(values, where)


def remaining_inertia_problem(tensor: np.ndarray, spin: np.ndarray) -> str | None:
    """
    Say why ``tensor - spin`` cannot be integrated with, or return None when it can.

    ``spin`` is the inertia effects carry in their own states
    (:meth:`MotionEffect.spin_inertia_B`); what is left, the body with its wheels' spin removed,
    must be positive definite: its smallest eigenvalue above 1e-12 of the largest moment, a margin
    over the eigen-solver's rounding (a wheel's ``Js`` equal to the body's whole moment about its
    axis leaves a zero there).
    """
    with np.errstate(all='ignore'):
        remaining = np.asarray(tensor, float) - spin
        finite = bool(np.all(np.isfinite(remaining)))
        smallest = float(np.linalg.eigvalsh(remaining).min()) if finite else math.nan
        largest = float(np.abs(np.linalg.eigvalsh(tensor)).max()) if finite else math.nan
    if finite and smallest > 1e-12 * largest:
        return None
    return (
        'the wheels leave I - sum(Js g g^T) not positive definite (smallest eigenvalue '
        f"{smallest:.6g} kg m^2, largest moment {largest:.6g} kg m^2): each wheel's spin "
        "inertia is part of the body's inertia, so Js must stay below the body's moment about "
        'its axis'
    )


def invariants_conserved(effects) -> frozenset:
    """Return what stays constant under all ``effects`` (torque-free: energy and momentum)."""
    kept = frozenset({ENERGY, MOMENTUM})
    for effect in effects:
        kept &= effect.conserves
    return kept


def _short(value) -> str:
    if isinstance(value, np.ndarray):
        return '[' + ', '.join(f'{x:g}' for x in value.ravel()) + ']'
    if isinstance(value, float):
        return f'{value:g}'
    if isinstance(value, list):
        return f'<{len(value)} entries>'
    return str(value)


__all__ = [
    'EFFECTS',
    'ENERGY',
    'MOMENTUM',
    'Effect',
    'FieldError',
    'MotionEffect',
    'OutputEffect',
    'OutputStream',
    'invariants_conserved',
    'parse_effect',
    'register',
    'remaining_inertia_problem',
]
