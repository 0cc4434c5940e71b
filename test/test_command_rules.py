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
The rules shared by the node, the offline replay and the plant, each written once.

The stamp of sample k (core/timing/grid.py) on one sample and on arrays; the refusal of a commanded
torque (core/commands/hold.py) on one command and on a batch of bodies; the timeout's boundary.
"""

from hypothesis import given, strategies as st
import numpy as np
from torquefree_ros.core.commands.hold import timed_out, torque_refusal, torque_refusals
from torquefree_ros.core.timing.grid import MAX_RATE, MIN_RATE, sample_stamp_ns, stamps_ns

rates = st.floats(MIN_RATE, MAX_RATE, allow_nan=False)
components = st.one_of(
    st.floats(-2.0, 2.0),
    st.sampled_from([float('nan'), float('inf'), -float('inf'), 1.0, -1.0]),
)


# k / rate <= 1e9 s: with the epoch, every stamp fits an int64 (as the node's MAX_STAMP_S keeps it)
@given(k=st.integers(0, 10**6), rate=rates, epoch_ns=st.integers(0, 2**62))
def test_the_stamp_of_one_sample_is_the_stamp_of_the_array_rule(k, rate, epoch_ns):
    times = np.array([k]) / rate  # the times a Simulation asks for: k / rate
    assert sample_stamp_ns(k, rate, epoch_ns) == int(stamps_ns(epoch_ns, times)[0])


@given(
    torques=st.lists(st.lists(components, min_size=3, max_size=3), min_size=1, max_size=8),
    max_torque=st.floats(0.5, 1.5),
)
def test_a_batch_refuses_exactly_the_bodies_one_command_would_be_refused_for(torques, max_torque):
    values = np.array(torques)
    not_finite, too_large = torque_refusals(values, np.full(len(torques), max_torque))
    for row, finite_refused, large_refused in zip(torques, not_finite, too_large):
        reason = torque_refusal(row, max_torque)
        assert finite_refused == reason.startswith('not finite')
        assert large_refused == reason.startswith('too large')


def test_a_command_times_out_exactly_timeout_after_its_stamp():
    timeout_ns = 500_000_000
    assert not timed_out(1_499_999_999, 1_000_000_000, timeout_ns)
    assert timed_out(1_500_000_000, 1_000_000_000, timeout_ns)
    arrays = timed_out(np.array([1_499_999_999, 1_500_000_000]), np.int64(10**9), timeout_ns)
    assert arrays.tolist() == [False, True]
