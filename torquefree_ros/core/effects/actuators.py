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
motor and friction alone change, then its angle ``theta_i`` relative to the body (rad, from 0 at
the start, not wrapped: ``wheel_states``' position), and the body is integrated with the inertia
less the wheels' spin, ``I_s = I - sum Js_i g_i g_i^T`` (:meth:`ReactionWheels.spin_inertia_B`)::

    h_i' = u_i - f_i,   theta_i' = Omega_i
    I_s w' = tau_ext - w x (I_s w + sum h_i g_i) - sum g_i (u_i - f_i)
    Omega_i = h_i / Js_i - g_i . w

The effect's state is ``(h_0, theta_0, h_1, theta_1, ...)``, a pair per wheel in ``wheels`` order
(a kernel entry each); none in hold mode (below). The angle costs one more component per wheel
and no torque: it is integrated, not derived, because it is the integral of ``Omega`` over the
whole run, which no sample holds.

``I_s`` must be positive definite (checked where the wheels meet the body: ``bound``, at scene
load). The motor and friction torques are internal: the inertial momentum ``R(q) H_B``, ``H_B =
I_s w + sum h_i g_i``, is constant without external torque whatever they are. The kinetic energy
``T = w . I_s w / 2 + sum h_i^2 / (2 Js_i)`` is constant only when every ``u_i`` and ``f_i`` is
zero; the effect says so in ``conserves``.

Motor torque. The input per wheel (:meth:`ReactionWheels.inputs`) comes from the scene or from a
controller, by ``mode``: ``schedule`` (the default) takes a constant ``torque`` per wheel, a
``schedule`` of ``{start, torque}`` held from each start, or zero; ``torque`` and ``speed`` take
commands (``sensor_msgs/JointState`` on ``topic``, default ``wheel_command``: ``effort`` motor
torques in N m, resp. ``velocity`` speed set-points in rad/s) through a
:class:`~torquefree_ros.core.commands.hold.CommandHold`, under the rules every command follows
(held from the first sample at or after its stamp, stale ones dropped, refusals counted). A
command naming some wheels leaves the others at their latest values. With no command in force
(none yet, or none for ``timeout`` simulated seconds) the motor torque is zero in both modes: a
speed-mode drive coasts rather than holding its last set-point, as a torque-mode wheel gets no
torque, so a controller that stops answering leaves the wheels to friction in either mode.

Speed mode: the drive's own speed loop, proportional, asks ``u_cmd = K (Omega_ref - Omega)`` with
``K = Js speed_bandwidth``: against a body held still the loop is first order with bandwidth
``speed_bandwidth`` rad/s (default 10); on a free body, wheel on principal axis ``a``, its pole is
``K / Js_eff = speed_bandwidth I_a / (I_a - Js)``. Being proportional, it settles ``f / K`` short
of the set-point under friction ``f`` (a drive's integral term would need a state of its own).
The loop's torque then meets the same limits as a commanded one. The held set-point of a drive
that is off is NaN, which the motor reads as zero torque. A ``wheel_torque_error`` fault turns the
loop's torque into ``scale u_cmd + bias`` before the limits (zero with the drive off: the bias
alone), at every stage of the integration: its ``(scale, bias)`` per wheel and interval come from
the hold's overrides (:meth:`ReactionWheels.loop_errors`), and reach the kernel in the effect's
slot of ``held`` (``held_slot``).

The command ``u_cmd`` (torque mode: the input; speed mode: the loop's) is clipped to
``+-max_torque``. Speed limit: Basilisk zeroes a torque that would speed the wheel further (``u
Omega >= 0``) once ``|Omega| >= max_speed``, a jump a step-size controller cannot step across
cleanly. Here the accelerating torque (``u Omega > 0``) is scaled by ``(max_speed - |Omega|) /
speed_band`` over the last ``speed_band`` below ``max_speed`` (default 1 % of it) and is zero at
and beyond ``max_speed``; a braking torque is never limited. The right-hand side stays continuous
(kinks at ``max_speed - speed_band`` and ``max_speed``), and a wheel's own motor never drives
``|Omega|`` to ``max_speed``: frictionless under a constant command it approaches ``max_speed`` as
``exp(-|u| t / (Js_eff speed_band))`` (``Js_eff`` below), with friction it settles where the scaled
torque equals ``f``. The body's own acceleration about ``g_i`` (external torques, the other wheels)
still moves the relative speed, past ``max_speed`` too, as in Basilisk.

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

Hold mode. ``mode: hold`` holds each wheel's relative speed exactly at its scene ``speed`` by an
ideal drive and takes no commands (a ``wheel_command`` on its ``topic`` is refused and counted as
``wrong mode``). With every ``Omega_i`` constant, ``H_B = I w + h``, ``h = sum Js_i Omega_i g_i``
constant (:meth:`ReactionWheels.held_momentum_B`), and the body is exactly the ``rotor``'s
gyrostat::

    I w' + w x (I w + h) = tau_ext        (I: the scene's locked inertia)

The effect then has no state of its own (``state_size`` 0: the integrator steps ``(w, q)`` alone,
as with a ``rotor``, so the two runs are the same numbers), its compiled entry is the rotor's
(``motion_kernels.ROTOR`` with ``h``), its Python torque the rotor's ``h x w``; each wheel's angle
is ``Omega_i t`` and its speed ``Omega_i``, exactly. The drive's torque that holds wheel ``i``
follows from the body's acceleration: ``Js_i (Omega_i' + g_i . w') = u_i - f_i`` with ``Omega_i'
= 0`` gives ``u_i = Js_i g_i . w' + f_i(Omega_i)`` (the drive overcomes the friction, which never
reaches the body). ``wheel_states`` reports it as the effort, ``w'`` from the whole right-hand
side at the sample (:meth:`ReactionWheels.held_efforts`); the hold stays ideal whatever it needs,
and ``/diagnostics`` counts the intervals whose mean drive torque ``Js_i g_i . (w_k - w_k-1) / dt
+ f_i`` (exact from two samples) exceeds ``max_torque`` as torque-limited time. ``max_speed``
bounds the scene ``speed`` only. No actuator fault acts on a held array (refused at load with the
fault's path): a stuck drive lets the wheel coast and an erring one drifts its speed, motions a
held array has no state to carry.

Presets. A wheel's ``preset: NAME`` names a published wheel (:mod:`.wheel_presets`: the table,
each row with its source and date) and fills its ``spin_inertia``, ``max_torque``,
``max_speed`` and ``coulomb`` where its source gives one; any of them written beside the preset
wins. An unknown name is refused at ``wheels[i].preset`` with the known ones.

The ``wheel_states`` output (:class:`WheelStates`) reports each wheel's angle, speed and the motor
torque it applies after the limits; :class:`WheelMonitor` what ``/diagnostics`` says of them.
"""

from __future__ import annotations

import bisect
from collections import Counter
import copy
import math

import numpy as np

from .base import (
    ENERGY,
    MOMENTUM,
    MotionEffect,
    OutputEffect,
    OutputStream,
    register,
    remaining_inertia_problem,
)
from .wheel_presets import PRESETS, with_preset
from ..checks.schema import (
    child,
    choice,
    FieldError,
    fields,
    listing,
    mapping,
    number,
    Param,
    text,
    topic_name,
    vector,
)
from ..commands.hold import CommandHold
from ..compiled import motion_kernels
from ..frames import quaternion

#: the speed limit's band when a wheel gives none: this fraction of its ``max_speed``
SPEED_BAND_FRACTION = 0.01
#: the Coulomb band when a wheel gives none, rad/s (~0.1 rpm)
COULOMB_BAND = 0.01
#: the speed loop's bandwidth when the effect gives none, rad/s (~1.6 Hz)
SPEED_BANDWIDTH = 10.0
#: the modes: the scene's own motor torques, a controller's motor torques or speed set-points, or
#: every wheel held at its scene speed by an ideal drive
MODES = ('schedule', 'torque', 'speed', 'hold')
#: why a held array refuses a command (its first words: the refusal's counted reason)
HELD_REFUSAL = (
    'wrong mode: wheels in hold mode take no commands (each is held at its scene speed)'
)

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
_WHEEL_FIELDS = {
    'preset': Param(
        choice(*PRESETS),
        None,
        'a published wheel whose spin_inertia, max_torque, max_speed and coulomb (where its '
        'source gives one) it fills '
        '(any of them given beside it wins): ' + ', '.join(PRESETS),
    ),
    'name': Param(
        text(),
        None,
        "the wheel's name in wheel_command and wheel_states (default wheel_I, I its index)",
    ),
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


def _wheel(value, path):
    """Check a wheel's mapping, its ``preset`` (if any) filling the fields it does not give."""
    if isinstance(value, dict) and value.get('preset') is not None:
        choice(*PRESETS)(value['preset'], child(path, 'preset'))
        value = with_preset(value)
    return fields(value, path, _WHEEL_FIELDS)


_TORQUES = listing(number(unit='N m'), min_length=1)
_SEGMENT = mapping(
    {
        'start': Param(number(minimum=0.0, unit='s'), description='time the segment starts, s'),
        'torque': Param(_TORQUES, description='the motor torque of each wheel, N m'),
    }
)


def motor_torque(speed, command, max_torque, max_speed, band, gain=0.0, scale=1.0, bias=0.0):
    """
    Return the motor torque a wheel at relative ``speed`` applies for ``command``.

    With a speed-loop ``gain`` (speed mode) ``command`` is a set-point (NaN: the drive is off,
    asking zero) and the drive asks ``gain (command - speed)``, under a ``wheel_torque_error``
    ``scale`` times that plus ``bias``. Clipped to ``+-max_torque``; a torque that speeds the
    wheel up fades out over the last ``band`` below ``max_speed`` (the module's speed limit). The
    kernel's ``_wheel_motor``.
    """
    if gain > 0.0:
        command = 0.0 if math.isnan(command) else gain * (command - speed)
        if scale != 1.0 or bias != 0.0:
            command = scale * command + bias
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


def wheel_terms(w1, w2, w3, h, command, p, scale=1.0, bias=0.0):
    """
    Return one wheel's torque on the body, its ``h' = u - f`` and its speed (plain floats).

    ``p``: the wheel's 14 kernel parameters (:data:`motion_kernels.REACTION_WHEEL`); ``scale``
    and ``bias`` a speed drive's torque error; the kernel's ``_reaction_wheel``, the same
    operations.
    """
    g1, g2, g3, Js = p[0], p[1], p[2], p[3]
    speed = h / Js - (g1 * w1 + g2 * w2 + g3 * w3)
    u = motor_torque(speed, command, p[4], p[5], p[6], p[12], scale, bias)
    f = friction_torque(speed, p[7], p[8], p[9], p[10], p[11])
    net = u - f
    torque = (
        h * (g2 * w3 - g3 * w2) - g1 * net,
        h * (g3 * w1 - g1 * w3) - g2 * net,
        h * (g1 * w2 - g2 * w1) - g3 * net,
    )
    return torque, net, speed


@register
class ReactionWheels(MotionEffect):
    """
    Balanced reaction wheels with motor limits and friction (the model: the module's docstring).

    State: per wheel its absolute axial momentum ``h_i = Js_i (Omega_i + g_i . w)``, N m s, then
    its angle ``theta_i``, rad; none when held (mode ``hold``: the rotor's gyrostat).
    """

    name = 'reaction_wheels'
    summary = (
        'balanced reaction wheels: motor torque per wheel (scheduled, or commanded as torques or '
        'speeds on wheel_command), clipped and speed-limited, viscous, Coulomb and Stribeck '
        'friction, or held at constant speed; total angular momentum conserved'
    )
    kernel_code = motion_kernels.REACTION_WHEEL
    message_type = 'sensor_msgs/msg/JointState'
    parameters = {
        'wheels': Param(
            listing(_wheel, min_length=1),
            description='the wheels, each {axis, spin_inertia, max_torque, max_speed, ...}',
        ),
        'torque': Param(_TORQUES, None, 'a constant motor torque per wheel, N m'),
        'schedule': Param(
            listing(_SEGMENT, min_length=1),
            None,
            'motor torques held from each segment start: [{start, torque: [per wheel]}]',
        ),
        'mode': Param(
            choice(*MODES),
            'schedule',
            "where the motor torques come from: the scene's torque or schedule (schedule), "
            'commands on topic: effort motor torques (torque) or velocity set-points (speed), or '
            'an ideal drive holding each wheel at its speed (hold: no commands)',
        ),
        'topic': Param(topic_name, 'wheel_command', 'the commands (sensor_msgs/JointState)'),
        'timeout': Param(
            number(positive=True, unit='s'),
            1.0,
            'simulated time without a command after which the motor torques are zero',
        ),
        'speed_bandwidth': Param(
            number(positive=True, unit='rad/s'),
            SPEED_BANDWIDTH,
            "speed mode: the drive's speed loop bandwidth, rad/s (gain Js speed_bandwidth)",
        ),
    }
    #: the effect's path in its scene (errors found when it meets the body name it)
    path = name

    @classmethod
    def from_parameters(cls, values, path):
        wheels = values['wheels']
        names = {}
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
            name = wheel_name(wheel, index)
            if name in names:
                raise FieldError(
                    child(where, 'name'),
                    f'{name!r} names wheels[{names[name]}] already: a command names each wheel',
                )
            names[name] = index
        torque, schedule = values['torque'], values['schedule']
        if torque is not None and schedule is not None:
            raise FieldError(
                path,
                "give either 'torque' (constant) or 'schedule' (piecewise constant), not both",
            )
        if values['mode'] != 'schedule':
            for key in ('torque', 'schedule'):
                if values[key] is not None:
                    raise FieldError(
                        child(path, key),
                        'mode hold: an ideal drive holds each wheel at its speed; leave out '
                        'torque and schedule'
                        if values['mode'] == 'hold'
                        else f"mode {values['mode']}: the motors take their {values['mode']} "
                        f"commands on {values['topic']!r}; leave out torque and schedule",
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

    def __init__(
        self,
        wheels,
        torque=None,
        schedule=None,
        mode='schedule',
        topic='wheel_command',
        timeout=1.0,
        speed_bandwidth=SPEED_BANDWIDTH,
    ):
        # values as plain floats and tuples, so that scenes loaded twice compare equal
        wheels = [_plain(wheel) for wheel in wheels]
        torque = None if torque is None else tuple(float(x) for x in torque)
        schedule = None if schedule is None else [_plain(segment) for segment in schedule]
        super().__init__(
            wheels=wheels,
            torque=torque,
            schedule=schedule,
            mode=mode,
            topic=topic,
            timeout=float(timeout),
            speed_bandwidth=float(speed_bandwidth),
        )
        self.mode = mode
        #: the wheels' names, in order (commands and wheel_states name them)
        self.names = tuple(wheel_name(wheel, index) for index, wheel in enumerate(wheels))
        self._index = {name: index for index, name in enumerate(self.names)}
        speed_mode = mode == 'speed'
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
                    wheel['spin_inertia'] * speed_bandwidth if speed_mode else 0.0,
                    0.0,  # the torque error's index in held (set by the compiled model)
                )
            )
            axes.append(g)
        #: each wheel's kernel parameters (motion_kernels.REACTION_WHEEL's order)
        self.rows = tuple(rows)
        self.count = len(rows)
        self.state_size = 2 * len(rows)
        #: spin axes g_i (rows, body frame) and spin inertias Js_i
        self.axes = np.array(axes)
        self.spin_inertias = np.array([row[3] for row in rows])
        self._limits = np.array([row[4:7] + row[12:13] for row in rows]).T  # max u, max speed, ...
        self._limit_rows = [row[4:7] + row[12:13] for row in rows]
        #: where each wheel enters its speed limit's band, ``max_speed - speed_band``, rad/s
        self.band_speeds = np.array([row[5] - row[6] for row in rows])
        #: the input while no command is in force: zero torque, or (speed mode) the drive off
        self.off = (math.nan if speed_mode else 0.0,) * len(rows)
        #: speed mode: each drive's torque error (scale, bias) on the piece, in a slot of held
        self.held_slot_size = 2 * len(rows) if speed_mode else 0
        #: commands change the inputs at sample times only
        self.holds_per_sample = mode not in ('schedule', 'hold')
        #: a controller's commands on topic (torque, speed); held: refused and counted
        self.commanded = mode in ('torque', 'speed')
        self.refuses_commands = mode == 'hold'
        #: the wheels' scene speeds, rad/s (hold mode: what the drive holds)
        self.speeds = np.array([wheel['speed'] for wheel in wheels])
        h = [0.0, 0.0, 0.0]
        for row, speed in zip(rows, self.speeds.tolist()):
            momentum = row[3] * speed
            h = [h[k] + momentum * row[k] for k in range(3)]
        #: hold mode: the wheels' constant momentum relative to the body, sum Js_i Omega_i g_i
        self.h_B = np.array(h)
        if mode == 'hold':  # the rotor's gyrostat: no state, the rotor's kernel entry
            self.state_size = 0
            self.kernel_code = motion_kernels.ROTOR
        #: hold mode: commands refused, by reason (a run's own count: see bound)
        self.refused: Counter = Counter()
        if schedule is None:
            self._starts = [0.0]
            self._commands = [torque if torque is not None else (0.0,) * len(rows)]
        else:
            self._starts = [0.0] + [s['start'] for s in schedule if s['start'] > 0.0]
            self._commands = ([(0.0,) * len(rows)] if schedule[0]['start'] > 0.0 else []) + [
                s['torque'] for s in schedule
            ]
        commanded = self.holds_per_sample or any(
            u != 0.0 for command in self._commands for u in command
        )
        # (held: the drive overcomes the friction, which never reaches the body)
        frictionless = mode == 'hold' or all(row[7] == row[8] == row[10] == 0.0 for row in rows)
        self.conserves = frozenset(
            {MOMENTUM} if commanded or not frictionless else {ENERGY, MOMENTUM}
        )

    # -- commands ---------------------------------------------------------------------------------
    @property
    def topic(self) -> str:
        return self.values['topic']

    @property
    def command_field(self) -> str:
        """Return the JointState field its commands fill: ``effort`` or ``velocity``."""
        return 'velocity' if self.mode == 'speed' else 'effort'

    def frame_id(self, body_frame: str, inertial_frame: str) -> None:
        """Return None: a joint command's ``header.frame_id`` names no frame (any is taken)."""
        return None

    def command(self, names, velocity, effort):
        """
        Read a ``sensor_msgs/JointState`` command: return ``(indices, values)`` or a refusal.

        ``names`` the wheels commanded (any order, each once), ``velocity`` and ``effort`` its
        fields (``position`` is not read). The refusal is a reason whose first words name the
        rule (counted in /diagnostics): ``unknown name``, ``repeated name``, ``wrong length``,
        ``both fields``, ``wrong mode`` (any command to a held array). Non-finite values are the
        hold's rule.
        """
        if self.mode == 'hold':
            return HELD_REFUSAL
        field = self.command_field
        given, other = (velocity, effort) if field == 'velocity' else (effort, velocity)
        other_field = 'effort' if field == 'velocity' else 'velocity'
        if len(velocity) and len(effort):
            return (
                f'both fields: effort and velocity both given; wheels in {self.mode} mode take '
                f'{field} alone'
            )
        if len(other) and not len(given):
            return (
                f'wrong mode: {other_field} given to wheels in {self.mode} mode, which take '
                f'{field} ({"rad/s" if field == "velocity" else "N m"})'
            )
        if not len(names) or len(given) != len(names):
            return f'wrong length: {len(names)} names and {len(given)} {field} values'
        indices = []
        for name in names:
            index = self._index.get(name)
            if index is None:
                known = ', '.join(self.names)
                return f'unknown name: {name[:80]!r} (wheels: {known[:200]})'
            if index in indices:
                return f'repeated name: {name[:80]!r}'
            indices.append(index)
        return indices, [float(x) for x in given]

    def receive(
        self, stamp_ns: int, frame_id: str, names, velocity, effort, arrival_ns=None
    ) -> tuple[bool, str]:
        """
        Offer a ``sensor_msgs/JointState`` command to the hold: ``(accepted, reason)``.

        Read by :meth:`command` (refused and counted when it cannot be), then held under the
        hold's rules; the node, the offline replay and the tests all come in here.
        """
        read = self.command(names, velocity, effort)
        if self.mode == 'hold':  # (no hold: the run's own count, reported by its monitor)
            self.refused[read.split(':', 1)[0]] += 1
            return False, read
        if isinstance(read, str):
            return self.hold.refuse(read)
        indices, values = read
        return self.hold.receive(
            stamp_ns, values, frame_id=frame_id, arrival_ns=arrival_ns, indices=indices
        )

    def bound(self, tensor):
        """
        Refuse wheels that leave the body's inertia less their spin not positive definite.

        Commanded: a copy with a hold of its own (every propagator, every run, starts without
        commands).
        """
        problem = remaining_inertia_problem(tensor, self.spin_inertia_B())
        if problem is not None:
            raise FieldError(child(self.path, 'wheels'), problem)
        if self.mode == 'hold':  # a count of refused commands of its own
            bound = copy.copy(self)
            bound.refused = Counter()
            return bound
        if self.mode == 'schedule':
            return self
        bound = copy.copy(self)
        bound.hold = CommandHold(self.values['timeout'], width=self.count, off=self.off)
        bound.hold.frame_id = None  # (any: see frame_id)
        return bound

    # -- inputs: what the motors are asked for ---------------------------------------------------
    def inputs(self, segment_start: float):
        """
        Return each wheel's input on the piece from ``segment_start``: N m, or rad/s (speed mode).

        Before the limits: a commanded effect's hold (``off`` when no command is in force), or the
        torque held from the latest schedule start at or before it (the constant ``torque``, or
        zero). The one source of the inputs the equations read.
        """
        if self.hold is not None:
            return self.hold.values_at(segment_start)
        return self._commands[bisect.bisect_right(self._starts, segment_start) - 1]

    def loop_errors(self, k: int) -> tuple[list, list]:
        """
        Return each speed drive's torque error on interval ``k``: ``(scales, biases)``.

        Its ``wheel_torque_error`` faults' overrides on the hold (components none, the wheel's
        index as their value: they leave the set-points as they are), in list order: ``s2 (s1 u
        + b1) + b2`` is ``(s2 s1) u + (s2 b1 + b2)``. ``(1, 0)`` where none acts.
        """
        scales, biases = [1.0] * self.count, [0.0] * self.count
        if self.hold is None or self.mode != 'speed':
            return scales, biases
        for override in self.hold.overrides:
            if override.components == () and override.scale is not None and override.covers(k):
                i, (scale,), (bias,) = int(override.values[0]), override.scale, override.bias
                scales[i], biases[i] = scale * scales[i], scale * biases[i] + bias
        return scales, biases

    def held_slot(self, segment_start):
        """Return the speed drives' torque errors on the piece: ``(scale_0, bias_0, ...)``."""
        scales, biases = self._errors_at(segment_start)
        return np.array([x for pair in zip(scales, biases) for x in pair])

    def held_inputs(self, segment_start):
        if self.mode == 'hold':
            return None
        held = np.zeros(self.state_size)
        held[0::2] = self.inputs(segment_start)
        return held

    def breakpoints(self):
        return tuple(self._starts[1:])

    def coasting_problem(self) -> str | None:
        """
        Say why the wheels are not coasting, or return None when they are.

        Coasting: mode ``schedule`` with every motor torque zero (no ``torque``, no ``schedule``,
        or zeros) and no friction (``viscous``, ``coulomb`` and a Stribeck ``static`` level all
        zero): then ``h_i' = u_i - f_i = 0``, and the body is a free gyrostat.
        """
        if self.mode == 'hold':
            return 'reaction wheels held at constant speed (the rotor: holds_speeds)'
        if self.mode != 'schedule':
            return f'reaction wheels in {self.mode} mode (commanded)'
        if any(u != 0.0 for command in self._commands for u in command):
            return 'reaction wheels with a motor torque'
        for wheel in self.values['wheels']:
            stribeck = wheel['stribeck'] or {'static': 0.0}
            if wheel['viscous'] != 0.0 or wheel['coulomb'] != 0.0 or stribeck['static'] != 0.0:
                return 'reaction wheels with friction'
        return None

    def inputs_before(self, times: np.ndarray) -> np.ndarray:
        """
        Return each wheel's input on the sample interval ending at each of ``times``, ``(N, n)``.

        Sample times ``t_k = k / rate`` of the run; at ``t = 0`` the input from ``t = 0`` (no
        command yet: ``off``). What the wheels felt arriving at a sample, known when it goes out
        (a controller's answer to it holds on the interval after it).
        """
        out = np.empty((len(times), self.count))
        for row, t in enumerate(np.asarray(times, dtype=float).tolist()):
            if self.hold is not None:  # (overridden where a fault acts)
                k = self.hold.interval_at(t)
                out[row] = self.hold.held_on(k - 1) if k > 0 else self.off
            else:
                piece = max(bisect.bisect_left(self._starts, t) - 1, 0)
                out[row] = self._commands[piece]
        return out

    def errors_before(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """
        Return the speed drives' torque errors on the intervals :meth:`inputs_before` reads.

        ``(scales, biases)``, each ``(N, n)``; None when no error can act (not speed mode). At
        ``t = 0`` none, as the input there is ``off`` whatever acts on interval 0.
        """
        if self.held_slot_size == 0 or self.hold is None:
            return None
        rows = []
        for t in np.asarray(times, dtype=float).tolist():
            k = self.hold.interval_at(t)
            rows.append(self.loop_errors(k - 1) if k > 0 else self.loop_errors(-1))
        scales = np.array([scale for scale, _ in rows])
        biases = np.array([bias for _, bias in rows])
        return scales, biases

    def applied(self, speeds: np.ndarray, inputs: np.ndarray, errors=None):
        """
        Return the motor torques the wheels apply, and where each limit acts.

        ``(u, torque_limited, speed_limited)`` for wheels at relative ``speeds`` given ``inputs``
        and a speed drive's torque ``errors`` (:meth:`errors_before`; None: none) (arrays of
        ``(..., n)``): :func:`motor_torque` element by element, the same operations;
        torque-limited where the asked torque exceeds ``max_torque``, speed-limited where the
        speed limit's band scales an accelerating torque down.
        """
        if speeds.shape == (1, self.count):  # one sample (a closed loop's): floats, ~10x faster
            return self._applied_once(
                speeds[0].tolist(),
                inputs[0].tolist(),
                None if errors is None else (errors[0][0].tolist(), errors[1][0].tolist()),
            )
        max_torque, max_speed, band, gain = self._limits
        with np.errstate(invalid='ignore'):
            asked = np.where(gain > 0.0, gain * (inputs - speeds), inputs)
            asked = np.where(np.isnan(inputs), 0.0, asked)
            if errors is not None:
                scales, biases = errors
                erring = (gain > 0.0) & ((scales != 1.0) | (biases != 0.0))
                asked = np.where(erring, scales * asked + biases, asked)
            u = np.minimum(np.maximum(asked, -max_torque), max_torque)
            torque_limited = np.abs(asked) > max_torque
            room = (max_speed - np.abs(speeds)) / band
            speed_limited = (u * speeds > 0.0) & (room < 1.0)
            u = np.where(speed_limited, u * np.maximum(room, 0.0), u)
        return u, torque_limited, speed_limited

    def _applied_once(self, speeds: list, inputs: list, errors=None):
        """:meth:`applied` of one sample, in floats: the same operations, element by element."""
        applied, torque_limited, speed_limited = [], [], []
        if errors is None:
            errors = (1.0,) * self.count, (0.0,) * self.count
        scales, biases = errors
        for speed, command, (max_torque, max_speed, band, gain), scale, bias in zip(
            speeds, inputs, self._limit_rows, scales, biases
        ):
            if math.isnan(command):
                asked = 0.0
            else:
                asked = gain * (command - speed) if gain > 0.0 else command
            if gain > 0.0 and (scale != 1.0 or bias != 0.0):
                asked = scale * asked + bias
            u = min(max(asked, -max_torque), max_torque)
            room = (max_speed - abs(speed)) / band
            limited = u * speed > 0.0 and room < 1.0
            applied.append(u * max(room, 0.0) if limited else u)
            torque_limited.append(abs(asked) > max_torque)
            speed_limited.append(limited)
        return np.array([applied]), np.array([torque_limited]), np.array([speed_limited])

    def monitor(self, rate: float) -> 'WheelMonitor':
        return WheelMonitor(self, rate)

    # -- the body ---------------------------------------------------------------------------------
    def spin_inertia_B(self):
        """Return ``sum Js g g^T``; zero when held (the body is integrated with the locked I)."""
        if self.mode == 'hold':
            return np.zeros((3, 3))
        return np.einsum('i,ij,ik->jk', self.spin_inertias, self.axes, self.axes)

    def kernel_parameters(self):
        if self.mode == 'hold':  # motion_kernels.ROTOR's: h
            return tuple(self.h_B.tolist())
        return tuple(value for row in self.rows for value in row)

    # -- held at constant speed: the rotor's gyrostat ---------------------------------------------
    def holds_speeds(self) -> bool:
        """
        Tell whether the array is held at constant speeds: mode ``hold``, no fault acting on it.

        Then the body is the free gyrostat of :meth:`held_momentum_B` with the locked inertia
        (actuator faults on a held array are refused at load, so mode ``hold`` is enough).
        """
        return self.mode == 'hold'

    def held_momentum_B(self) -> np.ndarray:
        """Return the held wheels' constant momentum ``h = sum Js_i Omega_i g_i``, N m s, body."""
        return self.h_B.copy()

    def held_efforts(self, times, omega_B, q_NB, internal, dynamics) -> np.ndarray:
        """
        Return the torque each held wheel's drive applies at each sample, ``(N, n)``, N m.

        ``u_i = Js_i g_i . w' + f_i(Omega_i)``, ``w'`` the body's acceleration from ``dynamics``'
        whole right-hand side at the sample (``omega_B``, ``q_NB``, ``internal``: the run's
        states there), on the piece that ends at it (a torque that changes at the sample acts
        after it; at ``t = 0`` the first piece's).
        """
        friction = [
            friction_torque(speed, *row[7:12])
            for speed, row in zip(self.speeds.tolist(), self.rows)
        ]
        moments = self.spin_inertias[:, None] * self.axes  # Js_i g_i, a row each
        out = np.empty((len(times), self.count))
        for row, t in enumerate(np.asarray(times, dtype=float).tolist()):
            y = np.concatenate([omega_B[row], q_NB[row], internal[row]])
            w_dot = dynamics.derivative(t, y, piece_start_before(dynamics, t))[:3]
            out[row] = moments @ w_dot + friction
        return out

    # -- the equations of motion (the kernel's operations, in plain floats) ----------------------
    def initial_state(self, omega0_B):
        if self.mode == 'hold':
            return np.empty(0)
        w1, w2, w3 = (float(x) for x in omega0_B)
        state = []
        for row, wheel in zip(self.rows, self.values['wheels']):
            state += [row[3] * (wheel['speed'] + (row[0] * w1 + row[1] * w2 + row[2] * w3)), 0.0]
        return np.array(state)

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        if self.mode == 'hold':  # Rotor.torque_B's operations
            return quaternion.cross(self.h_B, omega_B)
        w1, w2, w3 = omega_B.tolist()
        t1 = t2 = t3 = 0.0
        momenta = state.tolist()[0::2]
        scales, biases = self._errors_at(segment_start)
        for row, h, command, scale, bias in zip(
            self.rows, momenta, self._input_list(segment_start), scales, biases
        ):
            (e1, e2, e3), _, _ = wheel_terms(w1, w2, w3, h, command, row, scale, bias)
            t1, t2, t3 = t1 + e1, t2 + e2, t3 + e3
        return np.array([t1, t2, t3])

    def state_rate(self, t, omega_B, q_NB, state, segment_start):
        if self.mode == 'hold':
            return np.empty(0)
        w1, w2, w3 = omega_B.tolist()
        rates = []
        momenta = state.tolist()[0::2]
        scales, biases = self._errors_at(segment_start)
        for row, h, command, scale, bias in zip(
            self.rows, momenta, self._input_list(segment_start), scales, biases
        ):
            _, net, speed = wheel_terms(w1, w2, w3, h, command, row, scale, bias)
            rates += [net, speed]
        return np.array(rates)

    def _errors_at(self, segment_start):
        if self.held_slot_size == 0 or self.hold is None:
            return (1.0,) * self.count, (0.0,) * self.count
        return self.loop_errors(self.hold.interval_at(segment_start))

    def _input_list(self, segment_start):
        inputs = self.inputs(segment_start)
        return inputs.tolist() if isinstance(inputs, np.ndarray) else inputs

    # -- what the wheels carry --------------------------------------------------------------------
    def momenta(self, state: np.ndarray) -> np.ndarray:
        """
        Return each wheel's absolute axial momentum ``h_i`` from the effect's state, N m s.

        Not for a held array, which has no state (its momentum: :meth:`held_momentum_B`).
        """
        return state[..., 0::2]

    def wheel_angles(self, state: np.ndarray, times=None) -> np.ndarray:
        """
        Return each wheel's angle relative to the body from the effect's state, rad.

        Held (no state): ``Omega_i t`` at ``times`` (s), ``(N, n)``.
        """
        if self.mode == 'hold':
            return np.outer(np.asarray(times, dtype=float), self.speeds)
        return state[..., 1::2]

    def wheel_speeds(self, omega_B: np.ndarray, state: np.ndarray) -> np.ndarray:
        """
        Return each wheel's speed relative to the body, ``Omega_i = h_i / Js_i - g_i . w``, rad/s.

        Broadcasts over leading axes of ``omega_B`` and ``state``; held: the scene speeds.
        """
        if self.mode == 'hold':
            return np.broadcast_to(self.speeds, np.shape(omega_B)[:-1] + (self.count,)).copy()
        return self.momenta(state) / self.spin_inertias - np.einsum(
            'ij,...j->...i', self.axes, omega_B
        )

    def stored_momentum_B(self, omega_B: np.ndarray, state: np.ndarray) -> np.ndarray:
        """Return the momentum the wheels store relative to the body, ``sum Js_i Omega_i g_i``."""
        relative = self.spin_inertias * self.wheel_speeds(omega_B, state)
        return np.einsum('...i,ij->...j', relative, self.axes)

    def momentum_B(self, state):
        """
        Return ``sum h_i g_i``: with ``I_s w`` the whole momentum (``I w + sum Js Omega g``).

        Held: ``h``, with the locked ``I w`` the whole momentum (the rotor's).
        """
        if self.mode == 'hold':
            return np.broadcast_to(self.h_B, state.shape[:-1] + (3,))
        return np.einsum('...i,ij->...j', self.momenta(state), self.axes)

    def energy(self, state):
        """
        Return ``sum h_i^2 / (2 Js_i)``: with ``w . I_s w / 2`` the whole kinetic energy.

        Held: zero, as the rotor's (``w . I w / 2`` is then the gyrostat's constant).
        """
        if self.mode == 'hold':
            return np.zeros(state.shape[:-1])
        h = self.momenta(state)
        return 0.5 * np.einsum('...i,...i->...', h, h / self.spin_inertias)


def piece_start_before(dynamics, t: float) -> float:
    """
    Return where the smooth piece of ``dynamics`` that ends at ``t`` starts (0 at ``t = 0``).

    The latest of its stops before ``t``: the scene's breakpoints and, when commands change the
    torque at sample times, the sample time before ``t`` (``Dynamics.next_breakpoint``'s stops
    from the left; an environment window's end is not one: the environment is continuous there).
    """
    breakpoints = dynamics.breakpoints
    index = bisect.bisect_left(breakpoints, t) - 1
    start = breakpoints[index] if index >= 0 else 0.0
    rate = dynamics.sample_rate
    if rate is not None and t > 0.0:
        k = math.ceil(t * rate) - 1
        while k > 0 and k / rate >= t:
            k -= 1
        while (k + 1) / rate < t:
            k += 1
        start = max(start, k / rate)
    return start


def wheel_name(wheel: dict, index: int) -> str:
    """Return a wheel's name: its ``name``, or ``wheel_I`` for ``wheels[I]``."""
    return wheel['name'] if wheel.get('name') is not None else f'wheel_{index}'


class WheelMonitor:
    """
    What /diagnostics reports of one run's wheels, kept as the samples are computed.

    Per wheel: its speed and the fraction of ``max_speed`` it is at, the time spent torque-limited
    and speed-limited; the momentum the array stores. Time limited counts whole sample intervals:
    the interval before sample ``k`` counts when its input, applied at the state of sample ``k``,
    meets the limit (a sampled measure: a limit met and left between two samples is not seen).
    """

    def __init__(self, effect: ReactionWheels, rate: float):
        self.effect = effect
        self.period = 1.0 / rate
        self.torque_limited = np.zeros(effect.count, dtype=np.int64)
        self.speed_limited = np.zeros(effect.count, dtype=np.int64)
        self.speeds = np.zeros(effect.count)
        self.stored = np.zeros(3)
        self.seen = False
        self.last_omega_B = None  # held: the rates of the sample before the block

    def update(self, times, omega_B, state) -> None:
        """Take the samples at ``times`` (after the last taken): rates, the effect's states."""
        effect = self.effect
        speeds = effect.wheel_speeds(omega_B, state)
        if effect.mode == 'hold':
            torque_limited = self._held_limited(omega_B)
            speed_limited = np.zeros_like(torque_limited)
        else:
            _, torque_limited, speed_limited = effect.applied(
                speeds, effect.inputs_before(times), effect.errors_before(times)
            )
        after_start = np.asarray(times) > 0.0  # sample 0 ends no interval
        self.torque_limited += np.sum(torque_limited & after_start[:, None], axis=0)
        self.speed_limited += np.sum(speed_limited & after_start[:, None], axis=0)
        self.speeds = speeds[-1]
        self.stored = effect.stored_momentum_B(omega_B[-1], state[-1])
        self.seen = True

    def _held_limited(self, omega_B) -> np.ndarray:
        """
        Return where a held wheel's drive needs more than ``max_torque`` on the interval before.

        Its mean torque over the interval, ``Js_i g_i . (w_k - w_k-1) / dt + f_i(Omega_i)``
        (exact: the drive's torque is ``Js_i g_i . w' + f_i`` and ``f_i`` is constant); the first
        sample the monitor sees ends none it saw (False).
        """
        effect = self.effect
        first = self.last_omega_B is None
        before = omega_B[:1] if first else self.last_omega_B[None, :]
        self.last_omega_B = np.array(omega_B[-1], dtype=float)
        rates = np.diff(np.concatenate([before, omega_B]), axis=0) / self.period
        friction = [
            friction_torque(speed, *row[7:12])
            for speed, row in zip(effect.speeds.tolist(), effect.rows)
        ]
        mean = rates @ (effect.spin_inertias[:, None] * effect.axes).T + friction
        limited = np.abs(mean) > np.array([row[4] for row in effect.rows])
        if first:
            limited[0] = False
        return limited

    def diagnostics(self) -> tuple[dict, str]:
        """Return the diagnostic values (by key) and a warning ("" when none)."""
        if not self.seen:
            return {}, ''
        effect, values, saturated = self.effect, {}, []
        for index, name in enumerate(effect.names):
            speed = float(self.speeds[index])
            fraction = abs(speed) / effect.rows[index][5]
            values[f'wheels.{name}.speed'] = f'{speed:.6g}'
            values[f'wheels.{name}.speed_fraction'] = f'{fraction:.4f}'
            values[f'wheels.{name}.torque_limited_time'] = (
                f'{self.torque_limited[index] * self.period:.6g}'
            )
            values[f'wheels.{name}.speed_limited_time'] = (
                f'{self.speed_limited[index] * self.period:.6g}'
            )
            if abs(speed) >= effect.rows[index][5] - effect.rows[index][6]:
                saturated.append(name)
        values['wheels.momentum'] = f'{float(np.linalg.norm(self.stored)):.6g}'
        values['wheels.momentum_B'] = ' '.join(f'{x:.6g}' for x in self.stored.tolist())
        if effect.mode == 'hold':  # the commands refused, as command inputs report theirs
            refused = effect.refused.copy()
            values[f'{effect.topic}.accepted'] = '0'
            values[f'{effect.topic}.refused'] = (
                ', '.join(f'{reason} {count}' for reason, count in sorted(refused.items()))
                or '0'
            )
        warning = (
            f'wheels at their speed limit: {", ".join(saturated)}' if saturated else ''
        )
        return values, warning


@register
class WheelStates(OutputEffect):
    """
    The wheels as ``sensor_msgs/JointState``: a joint per wheel of the scene's reaction wheels.

    Per wheel, by its name (every ``reaction_wheels`` effect's wheels, in scene order):
    ``position`` its angle relative to the body (rad, from 0 at the start, not wrapped: the
    effect's state), ``velocity`` its speed ``Omega`` relative to the body (rad/s), ``effort``
    the motor torque it applies at the sample, after the limits (N m): the input of the interval
    that ends there (the one a controller's answer to the sample does not change yet; at sample 0
    the input from ``t = 0``, zero for commands) at the sample's speed.
    """

    name = 'wheel_states'
    summary = (
        'sensor_msgs/JointState of the reaction wheels: angle, speed relative to the body, '
        'motor torque applied after the limits'
    )
    message_type = 'sensor_msgs/msg/JointState'
    frame = 'body'
    layout = 'joint_states'
    parameters = {'topic': Param(topic_name, 'wheel_states'), 'rate': OutputEffect.RATE}
    #: the scene must have this effect (checked at load)
    reports_on = 'reaction_wheels'
    #: the joints' names, once bound to a run (:meth:`for_run`)
    names: tuple = ()

    def for_run(self, propagator):
        wheels = _wheel_effects(propagator)
        bound = copy.copy(self)
        bound.names = tuple(name for effect, _ in wheels for name in effect.names)
        return bound

    @property
    def layout_options(self) -> dict:
        return {'names': self.names}

    def stream(self, rate, propagator):
        return _WheelStatesStream(_wheel_effects(propagator), propagator.dynamics)


def _wheel_effects(propagator) -> list:
    """Return the ``reaction_wheels`` effects of ``propagator`` with their parts of the states."""
    dynamics = propagator.dynamics
    wheels = [
        (effect, part)
        for effect, part in zip(dynamics.effects, dynamics.slices)
        if isinstance(effect, ReactionWheels)
    ]
    if not wheels:
        raise ValueError('wheel_states: the scene has no reaction_wheels effect to report on')
    return wheels


class _WheelStatesStream(OutputStream):

    def __init__(self, wheels, dynamics):
        self.wheels = wheels
        self.dynamics = dynamics

    def rows(self, first, times, omega_B, q_NB, internal):
        positions, velocities, efforts = [], [], []
        for effect, part in self.wheels:
            state = internal[:, part]
            speeds = effect.wheel_speeds(omega_B, state)
            positions.append(effect.wheel_angles(state, times))
            velocities.append(speeds)
            if effect.mode == 'hold':  # the ideal drive's torque, from the body's acceleration
                efforts.append(
                    effect.held_efforts(times, omega_B, q_NB, internal, self.dynamics)
                )
            else:
                efforts.append(
                    effect.applied(
                        speeds, effect.inputs_before(times), effect.errors_before(times)
                    )[0]
                )
        return np.concatenate(positions + velocities + efforts, axis=1)


def _plain(value):
    """``value`` with arrays as tuples of floats, mappings and lists alike (comparable by ==)."""
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, np.ndarray):
        return tuple(float(x) for x in value.tolist())
    if isinstance(value, (list, tuple)):
        return tuple(_plain(item) for item in value)
    return value
