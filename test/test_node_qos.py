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
The node's QoS: what it offers and requests, and its warning when a peer's cannot match.

The warning is read from /rosout, where every node's log goes, as any participant would see it.
"""

from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from torquefree_ros.ros.qos import command_profile, sample_profile, TF_DEPTH, TF_MESSAGE


def _scene(tmp_path):
    path = tmp_path / 'commanded.yaml'
    path.write_text(
        'body: {inertia: [2.0, 2.0, 2.0]}\ninitial: {angular_velocity: [0.1, 0.0, 0.0]}\n'
        'effects:\n  - torque_command: {timeout: 0.5}\n'
    )
    return path


def _warnings_of(logs, node_name):
    return [m.msg for m in logs if m.name == node_name and m.level == Log.WARN]


def _rosout(harness):
    logs = []
    # /rosout is offered transient local: a late joiner still gets the last lines
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=1000,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    harness.client.create_subscription(Log, '/rosout', logs.append, qos)
    return logs


def test_tf_goes_out_at_tf2_ros_depth_and_the_rest_at_qos_depth():
    assert TF_DEPTH == 100  # tf2_ros::DynamicBroadcasterQoS's depth
    assert sample_profile(10, TF_MESSAGE).depth == 100
    assert sample_profile(1000, TF_MESSAGE).depth == 1000  # a larger qos_depth is never cut
    assert sample_profile(10, 'geometry_msgs/msg/PoseStamped').depth == 10
    assert sample_profile(10).reliability == ReliabilityPolicy.RELIABLE


def test_the_command_input_requests_best_effort_and_the_samples_are_offered_reliable(tmp_path):
    from sim_harness import connected_harness

    assert (
        command_profile(7).reliability == ReliabilityPolicy.BEST_EFFORT
        and command_profile(7).depth == 7
    )
    with connected_harness(publish_rate=50.0, scene=str(_scene(tmp_path))) as harness:
        namespace = harness.node.get_namespace()
        (command_input,) = harness.client.get_subscriptions_info_by_topic(
            f'{namespace}/torque_command'
        )
        assert command_input.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
        for topic in ('angular_velocity', 'attitude'):
            (publisher,) = harness.client.get_publishers_info_by_topic(f'{namespace}/{topic}')
            assert publisher.qos_profile.reliability == ReliabilityPolicy.RELIABLE
            assert publisher.qos_profile.durability == DurabilityPolicy.VOLATILE


def test_a_subscriber_asking_for_more_than_the_node_offers_gets_a_warning_naming_the_topic():
    from sim_harness import connected_harness

    with connected_harness(publish_rate=50.0) as harness:
        logs = _rosout(harness)
        node_name = harness.node.get_logger().name
        topic = f'{harness.node.get_namespace()}/angular_velocity'
        # transient local asks for samples sent before it joined: the node offers volatile only
        wanting = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=10,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        harness.client.create_subscription(
            Vector3Stamped, 'angular_velocity', lambda message: None, wanting
        )
        harness.spin_until(
            lambda: any(topic in text for text in _warnings_of(logs, node_name)),
            what="the node's warning on /rosout",
        )
        (warning,) = [text for text in _warnings_of(logs, node_name) if topic in text]
        assert warning == (
            f'{topic}: a subscription requests QoS this node does not offer (last policy in '
            'conflict: durability; offered: reliable, volatile, keep-last 10), so it receives no '
            'message from this node (incompatible subscriptions so far: 1)'
        )


def test_a_publisher_offering_less_than_a_subscription_requests_gets_a_warning():
    """
    A publisher offering less than a subscription requests gets a warning.

    The subscriptions' side of the same callbacks. The node's own command input requests best
    effort, volatile, no deadline: every publisher matches it, so a reliable subscription shows the
    warning.
    """
    from sim_harness import connected_harness
    from std_msgs.msg import Empty
    from torquefree_ros.ros.qos import subscription_warnings

    with connected_harness(publish_rate=50.0) as harness:
        logs = _rosout(harness)
        client = harness.client
        topic = client.resolve_topic_name('strict')
        reliable = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=5, reliability=ReliabilityPolicy.RELIABLE
        )
        client.create_subscription(
            Empty,
            'strict',
            lambda message: None,
            reliable,
            event_callbacks=subscription_warnings(client.get_logger(), topic, reliable),
        )
        client.create_publisher(
            Empty, 'strict', QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
        )
        harness.spin_until(
            lambda: _warnings_of(logs, client.get_logger().name), what='the warning on /rosout'
        )
        assert _warnings_of(logs, client.get_logger().name) == [
            f'{topic}: a publisher offers QoS this node does not accept '
            '(last policy in conflict: reliability; requested: reliable, volatile, keep-last 5), '
            'so none of its messages arrive (incompatible publishers so far: 1)'
        ]
