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
Several bodies side by side, in one process.

Nodes in their own namespaces, in one process and one context, each with a frame_prefix, publish
distinct body frames under one shared inertial frame. (/tf itself needs tf2_msgs: test_tf_live.py
checks it the same way.)
"""

from __future__ import annotations

import contextlib
import time

from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from torquefree_ros.ros.node import TorqueFreeSim

BODIES = ('sat1', 'sat2')


@contextlib.contextmanager
def formation(prefixed=True, positions=None, **parameters):
    """
    Run a node per body and a client in one context; yield (client, executor, nodes).

    A node per body in namespace /<body> (frame_prefix '<body>/' when ``prefixed``; ``position``
    ``positions[body]`` when given), and a client, all spun by one executor.
    """
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    nodes, client = [], None
    try:
        for body in BODIES:
            values = {**parameters, 'frame_prefix': f'{body}/'} if prefixed else dict(parameters)
            if positions is not None:
                values['position'] = positions[body]
            overrides = [Parameter(name, value=value) for name, value in values.items()]
            nodes.append(
                TorqueFreeSim(context=context, namespace=body, parameter_overrides=overrides)
            )
        client = rclpy.create_node('formation_client', context=context)
        for node in (*nodes, client):
            executor.add_node(node)
        yield client, executor, nodes
    finally:
        executor.shutdown()
        for node in [*nodes, client]:
            if node is not None:
                node.destroy_node()
        context.try_shutdown()


def spin_until(executor, condition, what, timeout=20.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'timed out after {timeout} s waiting for {what}'
        executor.spin_once(timeout_sec=0.05)


def test_two_namespaced_nodes_publish_distinct_body_frames_under_one_inertial_frame():
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE
    )
    with formation(publish_rate=50.0) as (client, executor, nodes):
        frames = {body: set() for body in BODIES}
        for body in BODIES:

            def note(message, body=body):
                frames[body].add(message.header.frame_id)

            client.create_subscription(Vector3Stamped, f'/{body}/angular_velocity', note, qos)
            client.create_subscription(QuaternionStamped, f'/{body}/attitude', note, qos)
        spin_until(
            executor,
            lambda: all(len(seen) == 2 for seen in frames.values()),
            'both topics of both bodies',
        )
        assert [node.get_fully_qualified_name() for node in nodes] == [
            '/sat1/torquefree',
            '/sat2/torquefree',
        ]
        assert [node.sample_loop.request.body_frame for node in nodes] == [
            'sat1/body',
            'sat2/body',
        ]
    # angular_velocity in each body's own frame, attitude in the one inertial frame
    assert frames == {'sat1': {'sat1/body', 'world'}, 'sat2': {'sat2/body', 'world'}}


def test_an_empty_prefix_keeps_the_body_frame_as_it_was():
    with formation(prefixed=False, publish_rate=50.0) as (_, _, nodes):
        assert [node.sample_loop.request.body_frame for node in nodes] == ['body', 'body']
