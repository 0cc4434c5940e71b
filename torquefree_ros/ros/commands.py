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
The node's command inputs: a subscription per effect of the scene that takes commands.

None otherwise. A ``torque_command`` effect's subscription hands every
``geometry_msgs/WrenchStamped`` to the running simulation's hold (``core.effects.commands``);
commanded ``reaction_wheels``' every ``sensor_msgs/JointState`` to the effect, which reads the
wheels' names and values (``ReactionWheels.receive``); ``magnetorquers``' every
``geometry_msgs/Vector3Stamped`` (a body dipole) to the effect (``Magnetorquers.receive``): the
hold accepts each or refuses it with a counted reason.

The command subscriptions are served by a thread of their own, not by the node's executor: it waits
on them alone (an rclpy wait set), takes each command as CDR bytes and decodes it as the bag tools
do (``bag.cdr``, with struct; a variable-length JointState too). The executor rebuilds its wait set
from every entity of the node for each callback and deserializes into Python messages: about 60 µs
a command, a fifth of a lock-step round trip (docs/bench/lockstep.md). The subscriptions' QoS event
handlers (the incompatible-QoS warnings) are served by the same thread: with rmw_fastrtps, a
subscription's events wake a wait set while its messages wait to be taken, so an executor holding
the events but not the subscription would spin.
"""

from __future__ import annotations

from contextlib import ExitStack
import threading
import time
from typing import Callable

from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from rclpy.callback_groups import CallbackGroup
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from .qos import command_profile, subscription_warnings
from .sample_loop import RunRequest
from ..bag.cdr import decode_joint_state, decode_stamped_doubles
from ..core.effects.commands import command_inputs

#: the command messages by type name, with their decoders (bytes -> the effect's arguments)
JOINT_STATE = 'sensor_msgs/msg/JointState'
VECTOR3_STAMPED = 'geometry_msgs/msg/Vector3Stamped'

WAIT_SLICE_NS = 100_000_000  # the longest the thread takes to notice a closed context
RELEASE_TIMEOUT = 1.0  # s: the longest retire waits for the thread to let go of a subscription


def command_effects(request: RunRequest | None) -> dict:
    """
    Map topic -> effect, for the effects of ``request`` that take or refuse commands.

    Those that take them, and held ``reaction_wheels`` (:func:`refusing_effects`).
    """
    if request is None:
        return {}
    taking = {effect.topic: effect for effect in command_inputs(request.propagator.effects)}
    return {**refusing_effects(request), **taking}


def refusing_effects(request: RunRequest | None) -> dict:
    """
    Map topic -> effect, for ``request``'s held ``reaction_wheels`` on a topic of their own.

    A held array takes no commands: each one on its topic is refused and counted (``wrong
    mode``, reported by the array's /diagnostics monitor), as a command in the wrong field is.
    On a topic a commanded effect takes, the commands are that effect's.
    """
    if request is None:
        return {}
    effects = request.propagator.effects
    taken = {effect.topic for effect in command_inputs(effects)}
    return {
        effect.topic: effect
        for effect in effects
        if effect.refuses_commands and effect.topic not in taken
    }


def decode_wrench_stamped(data: bytes) -> tuple[int, str, tuple, tuple]:
    """
    Decode ``(stamp_ns, frame_id, torque, force)`` from a ``WrenchStamped``'s CDR bytes.

    Little-endian CDR (what every rmw on this machine's architectures writes) by
    :func:`~torquefree_ros.bag.cdr.decode_stamped_doubles` (a Header, then force and torque);
    anything else through rclpy's deserializer.
    """
    try:
        stamp, frame_id, values = decode_stamped_doubles(data, 6)
        force_and_torque = values.tolist()
        return stamp, frame_id, tuple(force_and_torque[3:]), tuple(force_and_torque[:3])
    except ValueError:  # big-endian (or a frame_id that is not UTF-8): rclpy decides
        pass
    message = deserialize_message(data, WrenchStamped)
    stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
    torque, force = message.wrench.torque, message.wrench.force
    return (
        stamp,
        message.header.frame_id,
        (torque.x, torque.y, torque.z),
        (force.x, force.y, force.z),
    )


def decode_joint_command(data: bytes) -> tuple[int, str, list, tuple, tuple]:
    """
    Decode ``(stamp_ns, frame_id, names, velocity, effort)`` from a ``JointState``'s CDR bytes.

    Little-endian CDR by :func:`~torquefree_ros.bag.cdr.decode_joint_state` (struct); anything
    else through rclpy's deserializer. ``position`` is not read (a wheel command has none).
    """
    try:
        stamp, frame_id, names, _, velocity, effort = decode_joint_state(data)
        return stamp, frame_id, names, velocity, effort
    except ValueError:  # big-endian (or a string that is not UTF-8): rclpy decides
        pass
    message = deserialize_message(data, JointState)
    stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
    return (
        stamp,
        message.header.frame_id,
        list(message.name),
        tuple(message.velocity),
        tuple(message.effort),
    )


def decode_vector_command(data: bytes) -> tuple[int, str, tuple]:
    """
    Decode ``(stamp_ns, frame_id, vector)`` from a ``Vector3Stamped``'s CDR bytes.

    Little-endian CDR by :func:`~torquefree_ros.bag.cdr.decode_stamped_doubles` (a Header, then
    x, y, z); anything else through rclpy's deserializer.
    """
    try:
        stamp, frame_id, values = decode_stamped_doubles(data, 3)
        return stamp, frame_id, tuple(values.tolist())
    except ValueError:  # big-endian (or a frame_id that is not UTF-8): rclpy decides
        pass
    message = deserialize_message(data, Vector3Stamped)
    stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
    vector = message.vector
    return stamp, message.header.frame_id, (vector.x, vector.y, vector.z)


#: each command type's message class and decoder
_MESSAGES = {
    'geometry_msgs/msg/WrenchStamped': (WrenchStamped, decode_wrench_stamped),
    JOINT_STATE: (JointState, decode_joint_command),
    VECTOR3_STAMPED: (Vector3Stamped, decode_vector_command),
}


class _ServedApart(CallbackGroup):
    """A callback group no executor runs: its subscriptions are served by CommandInputs' thread."""

    def can_execute(self, entity) -> bool:
        return False

    def beginning_execution(self, entity) -> bool:
        return False

    def ending_execution(self, entity) -> None:
        pass


class CommandInputs:
    """
    The subscriptions that hand each command to the hold of the effect on its topic.

    ``holds()`` gives the running simulation's ``(effect, hold)`` pairs; a command goes to the
    hold of the effect on its topic. Refusals and an ignored force are logged once per run and
    reason. The subscriptions are taken by a thread of this object (see the module's docstring);
    :meth:`close` stops it.
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
        self._refusing: dict = {}  # topic -> the running run's held wheels (refusing_effects)
        self._group = _ServedApart()
        # the subscriptions' dict, shared by ensure/retire and the thread; a generation counts its
        # changes, and the thread says which generation it serves (it holds no older handle)
        self._turnover = threading.Condition()
        self._generation = 0
        self._serving = 0
        self._changed = GuardCondition(None, None, context=node.context)
        self._closing = False
        self._thread: threading.Thread | None = None

    def ensure(self, request: RunRequest) -> None:
        self._refusing = refusing_effects(request)
        for topic, effect in command_effects(request).items():
            if topic not in self._subscriptions:
                events = subscription_warnings(
                    self._node.get_logger(), self._node.resolve_topic_name(topic), self._qos
                )
                subscription = self._node.create_subscription(
                    _MESSAGES[effect.message_type][0],
                    topic,
                    _never_called,
                    self._qos,
                    callback_group=self._group,
                    event_callbacks=events,
                    raw=True,
                )
                with self._turnover:
                    self._subscriptions[topic] = subscription
                    self._generation += 1
        self._wake_thread()

    def retire(self, request: RunRequest | None) -> None:
        self._refusing = refusing_effects(request)
        with self._turnover:
            retired = [
                self._subscriptions.pop(topic)
                for topic in set(self._subscriptions) - set(command_effects(request))
            ]
            if not retired:
                return
            self._generation += 1
            generation = self._generation
        self._wake_thread()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            # rclpy defers destroying a subscription the thread's wait set still holds: gone
            # from the graph when retire returns, as before
            with self._turnover:
                self._turnover.wait_for(
                    lambda: self._serving >= generation or not thread.is_alive(),
                    RELEASE_TIMEOUT,
                )
        for subscription in retired:
            self._node.destroy_subscription(subscription)

    def close(self) -> None:
        """Stop the thread (before the node and its context go)."""
        self._closing = True
        thread, self._thread = self._thread, None
        if thread is not None:
            try:
                self._changed.trigger()
            except Exception:  # noqa: BLE001 - the context is gone: the thread sees it too
                pass
            if thread is not threading.current_thread():
                thread.join()
        self._changed.destroy()

    def resolved(self, topic: str) -> str | None:
        subscription = self._subscriptions.get(topic)
        return subscription.topic_name if subscription is not None else None

    def topic_names(self) -> list[str]:
        return [subscription.topic_name for subscription in self._subscriptions.values()]

    def _wake_thread(self) -> None:
        if self._closing:
            return
        if self._thread is None and self._subscriptions:
            self._thread = threading.Thread(
                target=self._serve, name='torquefree commands', daemon=True
            )
            self._thread.start()
        elif self._thread is not None:
            self._changed.trigger()  # wait on the new set of subscriptions

    def _serve(self) -> None:
        context = self._node.context
        while not self._closing and context.ok():
            with self._turnover:
                subscriptions = list(self._subscriptions.items())
                self._serving = self._generation
                self._turnover.notify_all()
            try:
                self._wait_and_take(subscriptions, context)
            except Exception as error:  # noqa: BLE001 - a closed context ends the thread quietly
                if self._closing or not context.ok():
                    return
                self._node.get_logger().error(f'command inputs: {type(error).__name__}: {error}')
                time.sleep(WAIT_SLICE_NS / 1e9)  # not a flood of the same error

    def _wait_and_take(self, subscriptions: list, context) -> None:
        events = [handler for _, sub in subscriptions for handler in sub.event_handlers]
        with ExitStack() as handles:
            for _, subscription in subscriptions:
                handles.enter_context(subscription.handle)
            for handler in events:
                handles.enter_context(handler)
            handles.enter_context(self._changed.handle)
            handles.enter_context(context.handle)
            wait_set = _rclpy.WaitSet(
                len(subscriptions), 1, 0, 0, 0, len(events), context.handle
            )
            while not self._closing:
                wait_set.clear_entities()
                for _, subscription in subscriptions:
                    wait_set.add_subscription(subscription.handle)
                for handler in events:
                    handler.add_to_wait_set(wait_set)
                wait_set.add_guard_condition(self._changed.handle)
                wait_set.wait(WAIT_SLICE_NS)
                if self._changed.handle.pointer in wait_set.get_ready_entities('guard_condition'):
                    return  # the subscriptions changed (or closing): wait on the new set
                for handler in events:
                    if handler.is_ready(wait_set):
                        event = handler.take_data()
                        if event is not None and handler.callback is not None:
                            handler.callback(event)
                ready = wait_set.get_ready_entities('subscription')
                for topic, subscription in subscriptions:
                    if subscription.handle.pointer in ready:
                        self._take_all(topic, subscription)
                if not context.ok():
                    return

    def _take_all(self, topic: str, subscription) -> None:
        message, decode = _MESSAGES[_type_name(subscription.msg_type)]
        while True:
            taken = subscription.handle.take_message(message, True)
            if taken is None:
                return
            self._receive(topic, decode(taken[0]))

    def _receive(self, topic: str, decoded: tuple) -> None:
        held = self._refusing.get(topic)
        if held is not None and len(decoded) == 5:  # refused and counted by the effect
            _, reason = held.receive(*decoded)
            self._once(
                held,
                'wrong mode',
                f'{topic}: command refused ({reason}); further refusals are only counted '
                '(/diagnostics)',
            )
            return
        for effect, hold in self._holds():
            if effect.topic != topic:
                continue
            if effect.message_type == JOINT_STATE:
                if len(decoded) != 5:  # (a wrench on the topic of another run's scene)
                    continue
                accepted, reason = effect.receive(*decoded)
            elif effect.message_type == VECTOR3_STAMPED:
                if len(decoded) != 3:
                    continue
                accepted, reason = effect.receive(*decoded)
            else:
                if len(decoded) != 4:
                    continue
                stamp, frame_id, torque, force = decoded
                accepted, reason = hold.receive(stamp, torque, force, frame_id)
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


def _type_name(message) -> str:
    """Return a message class's type name, ``pkg/msg/Type``."""
    return f'{message.__module__.split(".")[0]}/msg/{message.__name__}'


def _never_called(_message) -> None:
    """Stand in for the subscriptions' callback: no executor runs them (_ServedApart)."""


#: a command field -> what /diagnostics says while none is in force, and once timed out
_OFF = {
    'torque': ('zero', 'the torque is zero'),
    'dipole': ('zero dipole', 'the dipole is zero'),
}


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
        # what holds: a torque, a dipole, or wheels' motor torques (effort) or speed set-points
        # (velocity)
        field = getattr(effect, 'command_field', 'torque')
        off, zero = _OFF.get(field, ('zero motor torques', 'the motor torques are zero'))
        if last_index is not None:
            command = hold.in_force(last_index)
            values[prefix + field] = (
                off + ' (no command in force)'
                if command is None
                else ' '.join(f'{x:.9g}' for x in command.values)
            )
            if hold.timed_out(last_index):
                warnings.append(
                    f'{effect.topic}: no command for {effect.values["timeout"]:g} s: {zero}'
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
