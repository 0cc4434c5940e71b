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
Magnetorquers commanded by a controller, and the dipole they apply as an output.

``magnetorquers``: rods fixed in the body, rod ``i`` along the unit ``axis`` ``a_i`` (body frame)
with a dipole ``d_i`` of at most ``max_dipole`` A m^2 in magnitude. A controller asks for a body
dipole ``m*`` (``geometry_msgs/Vector3Stamped`` on ``topic``, body frame, A m^2); the rods take
the least-norm dipoles that make it, ``d = pinv(A^T) m*`` (``A`` the axes, a row each: with three
orthogonal rods ``d_i = a_i . m*``), each clipped to ``+-max_dipole`` on its own (saturation per
rod: a saturated command loses its direction as real rods do), and apply ``m = sum d_i a_i``. The
torque on the body is ``m x B_B``, ``B_B = R(q)^T B_N`` the Earth's field on the scene's orbit
exactly as ``residual_dipole`` reads it (IGRF-14 or the tilted dipole, ``field``; held per
environment window: ``environment.place``).

The commands are held by a :class:`~torquefree_ros.core.commands.hold.CommandHold` of the run
under ``torque_command``'s rules (held from the first sample at or after the stamp, stale ones
dropped, wrong frame or non-finite refused, ``off`` = zero dipole after ``timeout``); a command
with a component beyond ``max_command`` is refused as too large (the rods saturate far below it:
the limit guards against a unit error, such as a dipole in mA m^2).

The compiled path reads the applied dipole from a slot of its own in the kernels' ``held``
(:attr:`Magnetorquers.held_slot_size`, written by :meth:`Magnetorquers.held_slot` where each
piece starts; the layout: ``compiled/motion_kernels.py``).

``magnetorquer_dipole`` publishes ``m`` (``geometry_msgs/Vector3Stamped``, body frame, A m^2)
applied over the sample interval that ends at each sample (the one a controller's answer to the
sample does not change yet; zero at sample 0 and while no command is in force).
"""

from __future__ import annotations

import copy
import math

import numpy as np

from .base import OutputEffect, OutputStream, register
from .torques import FieldDipole
from ..checks.schema import (
    child,
    choice,
    FieldError,
    listing,
    mapping,
    number,
    Param,
    topic_name,
    vector,
)
from ..commands.hold import CommandHold
from ..compiled import motion_kernels
from ..environment.place import FIELD_MODELS

#: the rods' axes must span 3-D: the smallest singular value of the unit axes (rows) at least this
#: fraction of the largest (three rods within 0.06 deg of a plane are refused)
SPAN_TOLERANCE = 1e-3

_ROD = mapping(
    {
        'axis': Param(vector(3), description='the rod along [x, y, z] in the body frame'),
        'max_dipole': Param(
            number(positive=True, unit='A m^2'), description='its largest dipole, A m^2'
        ),
    }
)


@register
class Magnetorquers(FieldDipole):
    """Rods commanded with a body dipole: ``m x B_B`` (the model: the module's docstring)."""

    name = 'magnetorquers'
    summary = (
        'magnetorquer rods commanded with a body dipole (geometry_msgs/Vector3Stamped on '
        "magnetorquer_command, A m^2), saturated per rod: m x B on the scene's orbit"
    )
    message_type = 'geometry_msgs/msg/Vector3Stamped'
    holds_per_sample = True
    commanded = True
    kernel_code = motion_kernels.MAGNETORQUERS
    #: the applied dipole, held on each piece in a slot of the kernels' ``held``
    held_slot_size = 3
    #: what /diagnostics calls the values a command holds
    command_field = 'dipole'
    parameters = {
        'rods': Param(
            listing(_ROD, min_length=3),
            description='the rods, each {axis, max_dipole}; their axes must span 3-D',
        ),
        'field': Param(choice(*FIELD_MODELS), 'igrf'),
        'topic': Param(topic_name, 'magnetorquer_command', 'the commands (Vector3Stamped)'),
        'timeout': Param(
            number(positive=True, unit='s'),
            1.0,
            'simulated time without a command after which the dipole is zero',
        ),
        'max_command': Param(
            number(positive=True, unit='A m^2'),
            1.0e6,
            'a command with a larger dipole component is refused',
        ),
    }

    @classmethod
    def from_parameters(cls, values, path):
        rods = values['rods']
        for index, rod in enumerate(rods):
            if not max(abs(x) for x in rod['axis'].tolist()) > 0.0:
                raise FieldError(
                    child(child(child(path, 'rods'), index), 'axis'), 'must not be the zero vector'
                )
        singular = np.linalg.svd(_unit_axes(rods), compute_uv=False)
        if not singular[-1] >= SPAN_TOLERANCE * singular[0]:
            raise FieldError(
                child(path, 'rods'),
                'the axes must span 3-D (a dipole along any direction), but they lie in a '
                f'{"plane" if singular[1] >= SPAN_TOLERANCE * singular[0] else "line"} '
                f'(singular values {", ".join(f"{s:.3g}" for s in singular)})',
            )
        return cls(**values)

    def __init__(
        self,
        rods,
        field='igrf',
        topic='magnetorquer_command',
        timeout=1.0,
        max_command=1.0e6,
    ):
        # plain floats and tuples, so that scenes loaded twice compare equal
        rods = tuple(
            {'axis': tuple(float(x) for x in rod['axis']), 'max_dipole': float(rod['max_dipole'])}
            for rod in rods
        )
        super().__init__(
            rods=rods,
            field=field,
            topic=topic,
            timeout=float(timeout),
            max_command=float(max_command),
        )
        #: the rods' unit axes (rows, body frame) and their largest dipoles, A m^2
        self.axes = _unit_axes(rods)
        self.max_dipoles = np.array([rod['max_dipole'] for rod in rods])
        #: the least-norm rod dipoles of a body dipole: ``d = allocation @ m*`` (``pinv(A^T)``)
        self.allocation = np.linalg.pinv(self.axes.T)
        # the last wanted dipole and its applied one: a command holds for many pieces and samples
        self._last_applied = ((), np.zeros(3))

    # -- commands ---------------------------------------------------------------------------------
    @property
    def topic(self) -> str:
        return self.values['topic']

    def frame_id(self, body_frame: str, inertial_frame: str) -> str:
        """Return the ``header.frame_id`` its commands must carry: the body frame."""
        return body_frame

    def receive(self, stamp_ns: int, frame_id: str, dipole, arrival_ns=None) -> tuple[bool, str]:
        """
        Offer a commanded body dipole (A m^2) to the hold: ``(accepted, reason)``.

        A finite component beyond ``max_command`` is refused here as ``too large`` (counted by the
        hold); the rest are the hold's rules. The node, the offline replay and the tests all come
        in here.
        """
        values = [float(x) for x in dipole]
        reason = dipole_too_large(values, self.values['max_command'])
        if reason:
            return self.hold.refuse(reason)
        return self.hold.receive(stamp_ns, values, frame_id=frame_id, arrival_ns=arrival_ns)

    def bound(self, tensor):
        """
        Return a copy with a hold of its own: every propagator (every run) starts without commands.

        Placed on the scene's orbit first (when the scene loads).
        """
        if self.place is None:
            raise ValueError("magnetorquers: needs the scene's orbit (place it there first)")
        bound = copy.copy(self)
        bound.hold = CommandHold(self.values['timeout'], width=3)
        return bound

    # -- the dipole -------------------------------------------------------------------------------
    def rod_dipoles(self, wanted) -> np.ndarray:
        """Return each rod's dipole for the ``wanted`` body dipole (A m^2): least norm, clipped."""
        least_norm = self.allocation @ np.asarray(wanted, dtype=float)
        return np.clip(least_norm, -self.max_dipoles, self.max_dipoles)

    def applied_dipole(self, wanted) -> np.ndarray:
        """Return the body dipole the rods apply for the ``wanted`` one: ``sum d_i a_i``."""
        key = tuple(np.asarray(wanted, dtype=float).tolist())
        last, applied = self._last_applied
        if key != last:
            applied = self.rod_dipoles(key) @ self.axes
            applied.flags.writeable = False
            self._last_applied = (key, applied)
        return applied

    def held_slot(self, segment_start: float) -> np.ndarray:
        """Return the dipole applied on the piece from ``segment_start`` (zero: no command)."""
        return self.applied_dipole(self.hold.values_at(segment_start))

    def dipoles_before(self, times) -> np.ndarray:
        """
        Return the dipole applied on the sample interval ending at each of ``times``, ``(N, 3)``.

        Sample times of the run; at ``t = 0`` (and while none is in force) zero.
        """
        out = np.zeros((len(times), 3))
        for row, t in enumerate(np.asarray(times, dtype=float).tolist()):
            k = self.hold.interval_at(t)
            if k > 0:  # what held, a fault's override included (zero: no command in force)
                out[row] = self.applied_dipole(self.hold.held_on(k - 1))
        return out

    # -- the torque -------------------------------------------------------------------------------
    def kernel_parameters(self):
        return (float(self.quantity),)

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        # the kernel's operations (motion_kernels._magnetorquers), in its order
        return self.dipole_torque_B(self.held_slot(segment_start).tolist(), t, q_NB, segment_start)


def dipole_too_large(values: list, max_command: float) -> str:
    """
    Return why a commanded body dipole is refused as too large, or ``""``.

    ``values``: its components as Python floats (A m^2); a finite one beyond ``max_command`` in
    magnitude is too large (a non-finite command is the hold's to refuse: ``not finite``). The
    node's rule (:meth:`Magnetorquers.receive`) and the plant's (``Plant.step``'s ``dipole``).
    """
    if all(map(math.isfinite, values)) and max(map(abs, values), default=0.0) > max_command:
        return f'too large: a dipole component exceeds max_command {max_command:g} A m^2'
    return ''


def _unit_axes(rods) -> np.ndarray:
    """Return the rods' axes as unit rows (an axis of huge entries scaled first: no overflow)."""
    axes = []
    for rod in rods:
        axis = [float(x) for x in rod['axis']]
        scale = max(abs(x) for x in axis)
        axis = [x / scale for x in axis]
        norm = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
        axes.append([x / norm for x in axis])
    return np.array(axes)


@register
class MagnetorquerDipole(OutputEffect):
    """
    The dipole the magnetorquers apply, ``geometry_msgs/Vector3Stamped`` (A m^2, body frame).

    At each sample: the dipole applied over the interval that ends there (after the rods'
    saturation), summed over the scene's ``magnetorquers`` effects; zero at sample 0.
    """

    name = 'magnetorquer_dipole'
    summary = (
        'geometry_msgs/Vector3Stamped: the dipole the magnetorquers apply (A m^2, body frame, '
        'after saturation) over the interval ending at each sample'
    )
    message_type = 'geometry_msgs/msg/Vector3Stamped'
    frame = 'body'
    parameters = {'topic': Param(topic_name, 'magnetorquer_dipole'), 'rate': OutputEffect.RATE}
    #: the scene must have this effect (checked at load)
    reports_on = 'magnetorquers'

    def stream(self, rate, propagator):
        effects = [e for e in propagator.effects if isinstance(e, Magnetorquers)]
        if not effects:
            raise ValueError('magnetorquer_dipole: the scene has no magnetorquers to report on')
        return _DipoleStream(effects)


class _DipoleStream(OutputStream):

    def __init__(self, effects):
        self.effects = effects

    def rows(self, first, times, omega_B, q_NB, internal):
        return sum(effect.dipoles_before(times) for effect in self.effects)
