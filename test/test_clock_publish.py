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
``publish_clock``: /clock at real_time_factor 1 too, one message per sample at its stamp.

So a neighbour started with use_sim_time:=true follows the simulator (without it, such a neighbour
waits forever for a clock). In process, with a neighbour node on sim time.
"""

from __future__ import annotations

import time

import numpy as np
import rclpy
from rclpy.parameter import Parameter
from sim_harness import connected_harness, reset_epoch_ns

PERIOD = 10_000_000  # ns at 100 Hz


def test_at_real_time_factor_1_the_clock_is_the_sample_stamps_and_sim_time_neighbours_follow_it():
    with connected_harness(publish_rate=100.0, publish_clock=True) as harness:
        # the worked example: a neighbour on sim time (as RViz started with use_sim_time:=true)
        neighbour = rclpy.create_node(
            'neighbour',
            context=harness.context,
            namespace=harness.namespace,
            parameter_overrides=[Parameter('use_sim_time', value=True)],
        )
        harness.executor.add_node(neighbour)
        try:
            assert neighbour.get_clock().ros_time_is_active
            harness.spin_until(
                lambda: neighbour.get_clock().now().nanoseconds > 0,
                what="the neighbour's sim time",
            )
            harness.wait_samples(30)
            latest = max(harness.omega)
            harness.spin_until(
                lambda: max(harness.clock) >= latest, what='the clock of the latest sample'
            )
            stamps = set(harness.omega) & set(harness.q)
            clock = np.array(harness.clock)
            # one clock message per sample, at its stamp: every value a sample stamp, in order,
            # none repeated, and every sample received in the clock's window had its clock message
            window = {s for s in stamps if clock.min() <= s <= clock.max()}
            assert window <= set(clock.tolist()) and len(window) >= 20
            np.testing.assert_array_equal(np.diff(clock), PERIOD)  # the sample grid, no gap
            # wall-clock stamps (the start-up run's epoch is the wall time it started at)
            assert abs(time.time_ns() - int(clock.max())) < 5e9
            # the neighbour's now() is a clock value it received: a sample's stamp, never between
            # or ahead of the samples (so a tf lookup at now() finds data and does not extrapolate)
            harness.spin_until(
                lambda: neighbour.get_clock().now().nanoseconds in harness.omega,
                what="the neighbour's now() at a sample's stamp",
            )
        finally:
            harness.executor.remove_node(neighbour)
            neighbour.destroy_node()


def test_publish_clock_is_checked_like_the_others_and_takes_effect_at_the_next_reset():
    with connected_harness(publish_rate=100.0) as harness:
        node = harness.node
        assert node.count_publishers('/clock') == 0  # the default: none at real_time_factor 1
        (descriptor,) = node.describe_parameters(['publish_clock'])
        assert (
            'use_sim_time' in descriptor.description and 'next ~/reset' in descriptor.description
        )
        assert not descriptor.read_only
        (result,) = harness.set_parameters(publish_clock='yes')
        assert (
            not result.successful
            and result.reason == "publish_clock: expected true or false, got string 'yes'"
        )
        (result,) = harness.set_parameters(publish_clock=1)
        assert (
            not result.successful
            and 'publish_clock: expected true or false, got integer' in result.reason
        )
        (result,) = harness.set_parameters(publish_clock=True)
        assert result.successful, result.reason
        harness.wait_samples(5)
        assert node.count_publishers('/clock') == 0 and harness.clock == []  # not before the reset
        response = harness.reset()
        assert response.success, response.message
        epoch = reset_epoch_ns(response)
        harness.spin_until(
            lambda: node.count_publishers('/clock') == 1, what='the /clock publisher'
        )
        harness.spin_until(
            lambda: (
                harness.client.count_subscribers('/clock') >= 1
                and len([c for c in harness.clock if c >= epoch]) >= 10
            ),
            what='/clock after the reset',
        )
        clock = [c for c in harness.clock if c >= epoch]
        np.testing.assert_array_equal(np.diff(clock), PERIOD)
        # on the new run's grid: its samples' stamps
        assert all((c - epoch) % PERIOD == 0 for c in clock)
        # off again at the next reset: the clock stops (the publisher stays, as after a clock of
        # our own)
        (result,) = harness.set_parameters(publish_clock=False)
        assert result.successful, result.reason
        response = harness.reset()
        epoch = reset_epoch_ns(response)
        harness.wait_samples(10, after=epoch - 1)
        assert not [c for c in harness.clock if c >= epoch]
