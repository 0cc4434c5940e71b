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
The node's command inputs: a subscription per ``torque_command`` effect the scene names.

None otherwise. Each hands every ``geometry_msgs/WrenchStamped`` to the running simulation's hold
(``core.effects.commands``), which accepts it or refuses it with a counted reason.
"""

from __future__ import annotations

from typing import Callable

from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node

from .qos import command_profile, subscription_warnings
from .sample_loop import RunRequest
from ..core.effects.commands import command_inputs


def command_effects(request: RunRequest | None) -> dict:
    """Map topic -> effect, for the effects of ``request`` that take commands."""
    if request is None:
        return {}
    return {effect.topic: effect for effect in command_inputs(request.propagator.effects)}


class CommandInputs:
    """
    The subscriptions that hand each command to the hold of the effect on its topic.

    ``holds()`` gives the running simulation's ``(effect, hold)`` pairs; a command goes to the
    hold of the effect on its topic. Refusals and an ignored force are logged once per run and
    reason.
    """

    def __init__(
        self, node: Node, depth: int, holds: Callable[[], tuple], accepted: Callable[[], None]
    ):
        self._node = node
        self._holds = holds
        self._accepted = accepted  # called after a command went into its hold
        # best effort: it matches every controller (why: command_profile)
        self._qos = command_profile(depth)
        self._subscriptions: dict = {}
        self._logged: set = set()  # (id of the hold, what) already said

    def ensure(self, request: RunRequest) -> None:
        for topic in command_effects(request):
            if topic not in self._subscriptions:
                events = subscription_warnings(
                    self._node.get_logger(), self._node.resolve_topic_name(topic), self._qos
                )
                self._subscriptions[topic] = self._node.create_subscription(
                    WrenchStamped,
                    topic,
                    lambda message, topic=topic: self._receive(topic, message),
                    self._qos,
                    event_callbacks=events,
                )

    def retire(self, request: RunRequest | None) -> None:
        for topic in set(self._subscriptions) - set(command_effects(request)):
            self._node.destroy_subscription(self._subscriptions.pop(topic))

    def resolved(self, topic: str) -> str | None:
        subscription = self._subscriptions.get(topic)
        return subscription.topic_name if subscription is not None else None

    def topic_names(self) -> list[str]:
        return [subscription.topic_name for subscription in self._subscriptions.values()]

    def _receive(self, topic: str, message: WrenchStamped) -> None:
        stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
        torque, force = message.wrench.torque, message.wrench.force
        for effect, hold in self._holds():
            if effect.topic != topic:
                continue
            accepted, reason = hold.receive(
                stamp,
                (torque.x, torque.y, torque.z),
                (force.x, force.y, force.z),
                message.header.frame_id,
            )
            if not accepted:
                self._once(
                    hold,
                    reason.split(':', 1)[0],
                    f'{topic}: command refused ({reason}); further refusals '
                    'for this reason are only counted (/diagnostics)',
                )
            else:
                if hold.force_seen:
                    self._once(
                        hold,
                        'force',
                        f'{topic}: wrench.force is ignored: only the torque acts on the body',
                    )
                self._accepted()

    def _once(self, hold, what: str, text: str) -> None:
        key = (id(hold), what)
        if key not in self._logged:
            self._logged.add(key)
            self._node.get_logger().warning(text)


def command_diagnostics(
    holds, last_index: int | None, missed_steps: int, lockstep: bool
) -> tuple[dict, str]:
    """
    Return the diagnostic values of the command inputs and a warning ("" when none).

    The warning names: no command for ``timeout`` (the torque is zero), refusals, missed lock-step
    answers.
    """
    values, warnings = {}, []
    for effect, hold in holds:
        prefix = f'{effect.topic}.'
        refused = ', '.join(f'{reason} {count}' for reason, count in sorted(hold.refused.items()))
        values[prefix + 'accepted'] = str(hold.accepted)
        values[prefix + 'refused'] = refused or '0'
        if last_index is not None:
            command = hold.in_force(last_index)
            values[prefix + 'torque'] = (
                'zero (no command in force)'
                if command is None
                else ' '.join(f'{x:.9g}' for x in command.torque)
            )
            if hold.timed_out(last_index):
                warnings.append(
                    f'{effect.topic}: no command for {effect.values["timeout"]:g} s: '
                    'the torque is zero'
                )
        if hold.force_seen:
            values[prefix + 'force'] = 'ignored (only the torque acts)'
    if lockstep:
        values['lockstep_missed_steps'] = str(missed_steps)
        if missed_steps:
            warnings.append(
                f"lock-step: {missed_steps} samples computed without the controller's answer"
            )
    return values, '; '.join(warnings)
