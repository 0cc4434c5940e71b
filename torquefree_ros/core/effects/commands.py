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
Torque commanded by a controller: the ``torque_command`` effect.

Its commands are held by a :class:`~torquefree_ros.core.commands.hold.CommandHold` of the run (the
rules are written there): a command holds from the first sample at or after its stamp, so the
torque only changes at sample times and the numerical propagators stop at every sample time of such
a scene. Bound to a propagator, the effect gets a hold of its own (:meth:`TorqueCommand.bound`).
"""

from __future__ import annotations

import copy

from .base import MotionEffect, register
from ..checks.schema import choice, number, Param, topic_name
from ..commands.hold import CommandHold
from ..frames import quaternion


@register
class TorqueCommand(MotionEffect):
    name = 'torque_command'
    summary = (
        'torque from a controller (geometry_msgs/WrenchStamped on `topic`), '
        'held from the first sample at or after its stamp; zero after `timeout` without a command'
    )
    message_type = 'geometry_msgs/msg/WrenchStamped'
    holds_per_sample = True
    commanded = True
    parameters = {
        'topic': Param(topic_name, 'torque_command'),
        'frame': Param(choice('body', 'inertial'), 'body', 'the frame of wrench.torque'),
        'timeout': Param(
            number(positive=True, unit='s'),
            1.0,
            'simulated time without a command after which the torque is zero',
        ),
        'max_torque': Param(
            number(positive=True, unit='N m'),
            1.0e6,
            'a command with a larger torque component is refused',
        ),
    }

    def __init__(self, **values):
        super().__init__(**values)
        self.inertial = values['frame'] == 'inertial'
        self.uses_attitude = self.inertial
        self.hold: CommandHold | None = None

    @property
    def topic(self) -> str:
        return self.values['topic']

    def frame_id(self, body_frame: str, inertial_frame: str) -> str:
        """Return the ``header.frame_id`` its commands must carry."""
        return inertial_frame if self.inertial else body_frame

    def bound(self, tensor):
        """
        Return a copy with a hold of its own.

        Every propagator (every run) starts without commands.
        """
        bound = copy.copy(self)
        bound.hold = CommandHold(self.values['timeout'], self.values['max_torque'])
        return bound

    def held_torque(self, segment_start):
        return self.hold.values_at(segment_start), self.inertial

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        torque, inertial = self.held_torque(segment_start)
        return quaternion.rotate_inverse(q_NB, torque) if inertial else torque


def command_inputs(effects) -> tuple:
    """
    Return the effects among ``effects`` that take commands, each with its hold.

    ``effects`` are a propagator's, bound.
    """
    return tuple(effect for effect in effects if effect.takes_commands)
