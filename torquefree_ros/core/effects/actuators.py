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
Actuators: reaction wheels (the ``reaction_wheels`` effect).

The model is Schaub & Junkins' balanced wheels (*Analytical Mechanics of Space Systems*, ch. 4,
momentum exchange devices), the ``BalancedWheels`` model of Basilisk's
``reactionWheelStateEffector``. Wheel ``i`` spins about a unit axis ``g_i`` fixed in the body, with
spin inertia ``Js_i`` and speed ``Omega_i`` *relative to the body*; its motor puts ``u_i`` on the
wheel about ``+g_i`` (the body feels ``-u_i g_i``) and friction ``f_i(Omega_i)`` opposes the spin.
The scene's ``inertia`` ``I`` includes the wheels as if locked (their mass, transverse inertia and
``Js_i`` about ``g_i``). Then::

    H_B = I w + sum Js_i Omega_i g_i
    (I - sum Js_i g_i g_i^T) w' = tau_ext - w x H_B - sum g_i (u_i - f_i)
    Js_i (Omega_i' + g_i . w') = u_i - f_i

Each wheel's state is its absolute axial momentum ``h_i = Js_i (Omega_i + g_i . w)``, which the
motor and friction alone change, and the body is integrated with the inertia less the wheels' spin,
``I_s = I - sum Js_i g_i g_i^T`` (:meth:`ReactionWheels.spin_inertia_B`)::

    h_i' = u_i - f_i
    I_s w' = tau_ext - w x (I_s w + sum h_i g_i) - sum g_i (u_i - f_i)
    Omega_i = h_i / Js_i - g_i . w

``I_s`` must be positive definite (checked where the wheels meet the body: ``bound``, at scene
load). The motor and friction torques are internal: the inertial momentum ``R(q) H_B``, ``H_B =
I_s w + sum h_i g_i``, is constant without external torque whatever they are. The kinetic energy
``T = w . I_s w / 2 + sum h_i^2 / (2 Js_i)`` is constant only when every ``u_i`` and ``f_i`` is
zero; the effect says so in ``conserves``.

Motor torque. The command ``u_cmd`` (a constant ``torque`` per wheel, a ``schedule`` of ``{start,
torque}`` held from each start, or zero; :meth:`ReactionWheels.motor_torques`, which a command hold
can feed later) is clipped to ``+-max_torque``. Speed limit: Basilisk zeroes a torque that would
speed the wheel further (``u Omega >= 0``) once ``|Omega| >= max_speed``, a jump a step-size
controller cannot step across cleanly. Here the accelerating torque (``u Omega > 0``) is scaled by
``(max_speed - |Omega|) / speed_band`` over the last ``speed_band`` below ``max_speed`` (default
1 % of it) and is zero at and beyond ``max_speed``; a braking torque is never limited. The
right-hand side stays continuous (kinks at ``max_speed - speed_band`` and ``max_speed``), and a
wheel's own motor never drives ``|Omega|`` to ``max_speed``: frictionless under a constant command
it approaches ``max_speed`` as ``exp(-|u| t / (Js_eff speed_band))`` (``Js_eff`` below), with
friction it settles where the scaled torque equals ``f``. The body's own acceleration about ``g_i``
(external torques, the other wheels) still moves the relative speed, past ``max_speed`` too, as in
Basilisk.

Friction. ``f(Omega) = b Omega + sign(Omega) F(|Omega|)``: viscous ``b``, and the dry level ``F =
Fc`` (Coulomb) or, with ``stribeck: {static: Fs, speed: w_s}``, the Stribeck curve ``F = Fc + (Fs -
Fc) exp(-(|Omega| / w_s)^2)`` (Olsson, Åström, Canudas de Wit, Gäfvert & Lischinsky, "Friction
models and friction compensation", Eur. J. Control 4, 1998, sec. 3; Basilisk's own Stribeck term
has another shape and switches on from rest only, a memory a right-hand side has not). Inside
``|Omega| < coulomb_band`` (``w_c``, default 0.01 rad/s) the dry part is the straight line
``F(w_c) Omega / w_c`` (Basilisk's ``omegaLimitCycle`` rule): continuous through zero speed, so
the integrator neither chatters across ``Omega = 0`` nor stalls on a sign that flips every step.
Outside the band the law is the ideal one exactly. A coasting wheel (body otherwise at rest, wheel
on its principal axis ``a``, ``Js_eff = Js (I_a - Js) / I_a``) follows ``Omega_0 - Fc t / Js_eff``
until ``|Omega| = w_c`` and then decays as ``w_c exp(-Fc (t - t_1) / (Js_eff w_c))``: at the ideal
stop ``Js_eff |Omega_0| / Fc`` it is ``w_c / e``, and it stays within the band after, decaying to
the integrator's noise. A motor torque under the dry level leaves the wheel creeping at ``|Omega| <
w_c`` where the ideal law has it stuck. In the band the wheel's time constant is ``Js_eff w_c /
F(w_c)``: an explicit integrator's steps there are a few of it (DOP853's stability bound).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from .base import ENERGY, MOMENTUM, MotionEffect, register, remaining_inertia_problem
from ..checks.schema import child, FieldError, listing, mapping, number, Param, vector
from ..compiled import motion_kernels

#: the speed limit's band when a wheel gives none: this fraction of its ``max_speed``
SPEED_BAND_FRACTION = 0.01
#: the Coulomb band when a wheel gives none, rad/s (~0.1 rpm)
COULOMB_BAND = 0.01

_STRIBECK = mapping(
    {
        'static': Param(
            number(minimum=0.0, unit='N m'),
            description='the dry friction at rest Fs (at least coulomb), N m',
        ),
        'speed': Param(
            number(positive=True, unit='rad/s'),
            description='the Stribeck speed w_s over which it falls to coulomb, rad/s',
        ),
    }
)
_WHEEL = mapping(
    {
        'axis': Param(vector(3), description='the spin axis g, body frame (normalised)'),
        'spin_inertia': Param(
            number(positive=True, unit='kg m^2'),
            description="the wheel's inertia about its axis Js, kg m^2",
        ),
        'max_torque': Param(
            number(positive=True, unit='N m'), description='the motor torque limit, N m'
        ),
        'max_speed': Param(
            number(positive=True, unit='rad/s'),
            description='the speed past which the motor does not speed the wheel up, rad/s',
        ),
        'speed_band': Param(
            number(positive=True, unit='rad/s'),
            None,
            'the band below max_speed over which an accelerating torque fades out, rad/s '
            '(default 1 % of max_speed)',
        ),
        'viscous': Param(number(minimum=0.0, unit='N m s'), 0.0, 'viscous friction b, N m s'),
        'coulomb': Param(number(minimum=0.0, unit='N m'), 0.0, 'Coulomb friction Fc, N m'),
        'coulomb_band': Param(
            number(positive=True, unit='rad/s'),
            COULOMB_BAND,
            'the speed band about zero over which dry friction is linear, rad/s',
        ),
        'stribeck': Param(_STRIBECK, None, 'the Stribeck peak: {static, speed}'),
        'speed': Param(
            number(unit='rad/s'), 0.0, 'the initial speed relative to the body, rad/s'
        ),
    }
)
_TORQUES = listing(number(unit='N m'), min_length=1)
_SEGMENT = mapping(
    {
        'start': Param(number(minimum=0.0, unit='s'), description='time the segment starts, s'),
        'torque': Param(_TORQUES, description='the motor torque of each wheel, N m'),
    }
)


def motor_torque(speed, command, max_torque, max_speed, band):
    """
    Return the motor torque a wheel at relative ``speed`` applies for ``command``.

    Clipped to ``+-max_torque``; a torque that speeds the wheel up fades out over the last
    ``band`` below ``max_speed`` (the module's speed limit). The kernel's ``_wheel_motor``.
    """
    u = min(max(command, -max_torque), max_torque)
    if u * speed > 0.0:
        room = (max_speed - abs(speed)) / band
        if room < 1.0:
            u *= max(room, 0.0)
    return u


def friction_torque(speed, viscous, coulomb, band, excess, stribeck_speed):
    """
    Return the friction torque on a wheel at relative ``speed`` (it opposes the spin).

    Viscous plus dry (Coulomb, with a Stribeck ``excess = Fs - Fc`` over ``stribeck_speed``),
    the dry part linear inside ``|speed| < band``. The kernel's ``_wheel_friction``.
    """
    a = abs(speed)
    level = coulomb
    if excess != 0.0:
        x = max(a, band) / stribeck_speed
        level += excess * math.exp(-(x * x))
    dry = math.copysign(level, speed) if a >= band else level * (speed / band)
    return viscous * speed + dry


def wheel_terms(w1, w2, w3, h, command, p):
    """
    Return one wheel's torque on the body and its ``h' = u - f`` (plain floats).

    ``p``: the wheel's 12 kernel parameters (:data:`motion_kernels.REACTION_WHEEL`); the kernel's
    ``_reaction_wheel``, the same operations.
    """
    g1, g2, g3, Js = p[0], p[1], p[2], p[3]
    speed = h / Js - (g1 * w1 + g2 * w2 + g3 * w3)
    u = motor_torque(speed, command, p[4], p[5], p[6])
    f = friction_torque(speed, p[7], p[8], p[9], p[10], p[11])
    net = u - f
    torque = (
        h * (g2 * w3 - g3 * w2) - g1 * net,
        h * (g3 * w1 - g1 * w3) - g2 * net,
        h * (g1 * w2 - g2 * w1) - g3 * net,
    )
    return torque, net


@register
class ReactionWheels(MotionEffect):
    """
    Balanced reaction wheels with motor limits and friction (the model: the module's docstring).

    State: each wheel's absolute axial momentum ``h_i = Js_i (Omega_i + g_i . w)``, N m s.
    """

    name = 'reaction_wheels'
    summary = (
        'balanced reaction wheels: motor torque per wheel (clipped, speed-limited), viscous, '
        'Coulomb and Stribeck friction; total angular momentum conserved'
    )
    kernel_code = motion_kernels.REACTION_WHEEL
    parameters = {
        'wheels': Param(
            listing(_WHEEL, min_length=1),
            description='the wheels, each {axis, spin_inertia, max_torque, max_speed, ...}',
        ),
        'torque': Param(_TORQUES, None, 'a constant motor torque per wheel, N m'),
        'schedule': Param(
            listing(_SEGMENT, min_length=1),
            None,
            'motor torques held from each segment start: [{start, torque: [per wheel]}]',
        ),
    }
    #: the effect's path in its scene (errors found when it meets the body name it)
    path = name

    @classmethod
    def from_parameters(cls, values, path):
        wheels = values['wheels']
        for index, wheel in enumerate(wheels):
            where = child(child(path, 'wheels'), index)
            if not max(abs(x) for x in wheel['axis'].tolist()) > 0.0:
                raise FieldError(child(where, 'axis'), 'must not be the zero vector')
            band = wheel['speed_band']
            if band is not None and band > wheel['max_speed']:
                raise FieldError(
                    child(where, 'speed_band'),
                    f'must not exceed max_speed ({wheel["max_speed"]:g} rad/s), got {band:g}',
                )
            if abs(wheel['speed']) > wheel['max_speed']:
                raise FieldError(
                    child(where, 'speed'),
                    f'|{wheel["speed"]:g}| rad/s is beyond max_speed ({wheel["max_speed"]:g} '
                    'rad/s; speeds are rad/s, not rpm)',
                )
            stribeck = wheel['stribeck']
            if stribeck is not None and stribeck['static'] < wheel['coulomb']:
                raise FieldError(
                    child(child(where, 'stribeck'), 'static'),
                    f'must be at least coulomb ({wheel["coulomb"]:g} N m), '
                    f'got {stribeck["static"]:g}',
                )
        torque, schedule = values['torque'], values['schedule']
        if torque is not None and schedule is not None:
            raise FieldError(
                path,
                "give either 'torque' (constant) or 'schedule' (piecewise constant), not both",
            )
        count = len(wheels)
        if torque is not None and len(torque) != count:
            raise FieldError(
                child(path, 'torque'),
                f'expected {count} numbers (one per wheel), got {len(torque)}',
            )
        for index, segment in enumerate(schedule or ()):
            where = child(child(path, 'schedule'), index)
            if len(segment['torque']) != count:
                raise FieldError(
                    child(where, 'torque'),
                    f'expected {count} numbers (one per wheel), got {len(segment["torque"])}',
                )
            if index and segment['start'] <= schedule[index - 1]['start']:
                raise FieldError(
                    child(where, 'start'),
                    f'segments must start in increasing order, got {segment["start"]:g} after '
                    f'{schedule[index - 1]["start"]:g}',
                )
        effect = cls(**values)
        effect.path = path
        return effect

    def __init__(self, wheels, torque=None, schedule=None):
        # values as plain floats and tuples, so that scenes loaded twice compare equal
        wheels = [_plain(wheel) for wheel in wheels]
        torque = None if torque is None else tuple(float(x) for x in torque)
        schedule = None if schedule is None else [_plain(segment) for segment in schedule]
        super().__init__(wheels=wheels, torque=torque, schedule=schedule)
        rows, axes = [], []
        for wheel in wheels:
            axis = wheel['axis']
            scale = max(abs(x) for x in axis)  # (no overflow for huge entries)
            g = [x / scale for x in axis]
            norm = math.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
            g = [x / norm for x in g]
            band = wheel['speed_band']
            stribeck = wheel['stribeck'] or {'static': wheel['coulomb'], 'speed': 1.0}
            rows.append(
                (
                    *g,
                    wheel['spin_inertia'],
                    wheel['max_torque'],
                    wheel['max_speed'],
                    SPEED_BAND_FRACTION * wheel['max_speed'] if band is None else band,
                    wheel['viscous'],
                    wheel['coulomb'],
                    wheel['coulomb_band'],
                    stribeck['static'] - wheel['coulomb'],
                    stribeck['speed'],
                )
            )
            axes.append(g)
        #: each wheel's kernel parameters (motion_kernels.REACTION_WHEEL's order)
        self.rows = tuple(rows)
        self.state_size = len(rows)
        #: spin axes g_i (rows, body frame) and spin inertias Js_i
        self.axes = np.array(axes)
        self.spin_inertias = np.array([row[3] for row in rows])
        if schedule is None:
            self._starts = [0.0]
            self._commands = [torque if torque is not None else (0.0,) * len(rows)]
        else:
            self._starts = [0.0] + [s['start'] for s in schedule if s['start'] > 0.0]
            self._commands = ([(0.0,) * len(rows)] if schedule[0]['start'] > 0.0 else []) + [
                s['torque'] for s in schedule
            ]
        commanded = any(u != 0.0 for command in self._commands for u in command)
        frictionless = all(row[7] == row[8] == row[10] == 0.0 for row in rows)
        self.conserves = frozenset(
            {MOMENTUM} if commanded or not frictionless else {ENERGY, MOMENTUM}
        )

    # -- inputs: what the motors are asked for ---------------------------------------------------
    def motor_torques(self, segment_start: float) -> tuple[float, ...]:
        """
        Return each wheel's commanded motor torque on the piece from ``segment_start``, N m.

        Before the limits: the torque held from the latest schedule start at or before it (the
        constant ``torque``, or zero). The one source of the commands: a command hold feeds it.
        """
        return self._commands[bisect.bisect_right(self._starts, segment_start) - 1]

    def held_inputs(self, segment_start):
        return np.array(self.motor_torques(segment_start), dtype=float)

    def breakpoints(self):
        return tuple(self._starts[1:])

    # -- the body ---------------------------------------------------------------------------------
    def bound(self, tensor):
        """Refuse wheels that leave the body's inertia less their spin not positive definite."""
        problem = remaining_inertia_problem(tensor, self.spin_inertia_B())
        if problem is not None:
            raise FieldError(child(self.path, 'wheels'), problem)
        return self

    def spin_inertia_B(self):
        return np.einsum('i,ij,ik->jk', self.spin_inertias, self.axes, self.axes)

    def kernel_parameters(self):
        return tuple(value for row in self.rows for value in row)

    # -- the equations of motion (the kernel's operations, in plain floats) ----------------------
    def initial_state(self, omega0_B):
        w1, w2, w3 = (float(x) for x in omega0_B)
        return np.array(
            [
                row[3] * (wheel['speed'] + (row[0] * w1 + row[1] * w2 + row[2] * w3))
                for row, wheel in zip(self.rows, self.values['wheels'])
            ]
        )

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        w1, w2, w3 = omega_B.tolist()
        t1 = t2 = t3 = 0.0
        for row, h, command in zip(self.rows, state.tolist(), self.motor_torques(segment_start)):
            (e1, e2, e3), _ = wheel_terms(w1, w2, w3, h, command, row)
            t1, t2, t3 = t1 + e1, t2 + e2, t3 + e3
        return np.array([t1, t2, t3])

    def state_rate(self, t, omega_B, q_NB, state, segment_start):
        w1, w2, w3 = omega_B.tolist()
        return np.array(
            [
                wheel_terms(w1, w2, w3, h, command, row)[1]
                for row, h, command in zip(
                    self.rows, state.tolist(), self.motor_torques(segment_start)
                )
            ]
        )

    # -- what the wheels carry --------------------------------------------------------------------
    def wheel_speeds(self, omega_B: np.ndarray, state: np.ndarray) -> np.ndarray:
        """
        Return each wheel's speed relative to the body, ``Omega_i = h_i / Js_i - g_i . w``, rad/s.

        Broadcasts over leading axes of ``omega_B`` and ``state``.
        """
        return state / self.spin_inertias - np.einsum('ij,...j->...i', self.axes, omega_B)

    def momentum_B(self, state):
        """Return ``sum h_i g_i``: with ``I_s w`` the whole momentum (``I w + sum Js Omega g``)."""
        return np.einsum('...i,ij->...j', state, self.axes)

    def energy(self, state):
        """Return ``sum h_i^2 / (2 Js_i)``: with ``w . I_s w / 2`` the whole kinetic energy."""
        return 0.5 * np.einsum('...i,...i->...', state, state / self.spin_inertias)


def _plain(value):
    """``value`` with arrays as tuples of floats, mappings and lists alike (comparable by ==)."""
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, np.ndarray):
        return tuple(float(x) for x in value.tolist())
    if isinstance(value, (list, tuple)):
        return tuple(_plain(item) for item in value)
    return value
