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
The node's command inputs, served by a thread of their own rather than by the executor.

A command's CDR bytes decode to what rclpy's own deserializer gives, for every header length
(padding before the doubles) and either byte order; commands reach their hold with no executor
spinning at all; neither the command subscription nor its QoS events are left to an executor
(an executor holding the events but not the subscription spins: rmw_fastrtps wakes it for the
unread messages); the thread ends with the node.
"""

from __future__ import annotations

import struct
import threading
import time

from geometry_msgs.msg import WrenchStamped
from hypothesis import given, settings, strategies as st
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from torquefree_ros.ros.commands import decode_wrench_stamped
from torquefree_ros.ros.node import TorqueFreeSim

THREAD_NAME = 'torquefree commands'
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


def _wrench(sec, nanosec, frame_id, force, torque) -> WrenchStamped:
    message = WrenchStamped()
    message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
    message.header.frame_id = frame_id
    message.wrench.force.x, message.wrench.force.y, message.wrench.force.z = force
    message.wrench.torque.x, message.wrench.torque.y, message.wrench.torque.z = torque
    return message


@settings(max_examples=200, deadline=None)
@given(
    sec=st.integers(-(2**31), 2**31 - 1),
    nanosec=st.integers(0, 999_999_999),
    frame_id=st.text(st.characters(codec='utf-8', exclude_characters='\x00'), max_size=12),
    force=st.tuples(finite, finite, finite),
    torque=st.tuples(finite, finite, finite),
)
def test_a_command_decodes_as_rclpy_deserializes_it(sec, nanosec, frame_id, force, torque):
    data = serialize_message(_wrench(sec, nanosec, frame_id, force, torque))
    reference = deserialize_message(data, WrenchStamped)
    stamp, frame, decoded_torque, decoded_force = decode_wrench_stamped(data)
    assert stamp == reference.header.stamp.sec * 1_000_000_000 + reference.header.stamp.nanosec
    assert frame == reference.header.frame_id
    wrench = reference.wrench
    assert decoded_torque == (wrench.torque.x, wrench.torque.y, wrench.torque.z)
    assert decoded_force == (wrench.force.x, wrench.force.y, wrench.force.z)


def test_a_big_endian_command_goes_through_rclpy_deserializer():
    frame = b'body\x00'
    data = b'\x00\x00\x00\x00' + struct.pack('>iII', 7, 5, len(frame)) + frame
    data += b'\x00' * (-(len(data) - 4) % 8)  # the doubles are 8-aligned after the 4-byte header
    data += struct.pack('>6d', 1.0, 2.0, 3.0, 0.25, -0.5, 0.75)
    assert decode_wrench_stamped(data) == (
        7_000_000_005,
        'body',
        (0.25, -0.5, 0.75),
        (1.0, 2.0, 3.0),
    )


def _node(context) -> TorqueFreeSim:
    overrides = [
        Parameter('scene', value='detumble'),
        Parameter('lockstep', value=False),
    ]
    return TorqueFreeSim(context=context, parameter_overrides=overrides)


def _command_threads() -> list:
    return [thread for thread in threading.enumerate() if thread.name == THREAD_NAME]


def test_commands_reach_the_hold_without_an_executor_and_the_thread_ends_with_the_node():
    before = len(_command_threads())
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = _node(context)
        controller = rclpy.create_node('controller', context=context)
        publisher = controller.create_publisher(
            WrenchStamped,
            'torque_command',
            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE),
        )
        ((_, hold),) = node._command_holds()
        deadline = time.monotonic() + 20.0
        while hold.accepted + sum(hold.refused.values()) == 0:
            assert time.monotonic() < deadline, 'no command reached the hold'
            publisher.publish(_wrench(0, 0, 'body', (0.0, 0.0, 0.0), (0.001, -0.002, 0.003)))
            time.sleep(0.05)
        assert hold.accepted >= 1 and not hold.refused
        assert hold.commands[-1].values.tolist() == [0.001, -0.002, 0.003]
        assert len(_command_threads()) == before + 1
        controller.destroy_node()
        node.destroy_node()
        assert len(_command_threads()) == before
    finally:
        context.try_shutdown()


def test_no_executor_waits_on_the_command_subscription_or_its_events():
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = _node(context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        (subscription,) = [s for s in node.subscriptions if s.msg_type is WrenchStamped]
        assert subscription.event_handlers
        assert not executor.can_execute(subscription)
        assert not any(executor.can_execute(handler) for handler in subscription.event_handlers)
        # everything else of the node stays the executor's
        others = [w for w in node.waitables if w not in subscription.event_handlers]
        assert others and all(executor.can_execute(waitable) for waitable in others)
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()
