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
Test kit: the simulator node in process, stepped by your test, with the exact truth beside it.

    from torquefree_ros.testing import simulator

    with simulator(scene="estimator") as sim:
        estimator = MyEstimator(context=sim.context, namespace=sim.namespace)
        sim.add_node(estimator)
        sim.advance(100)            # 100 samples out, each processed by every node added
        truth = sim.truth(sim.t)    # the exact state at the last sample's time

The pytest plugin (``torquefree_ros.testing.pytest_plugin``, registered as a ``pytest11`` entry
point) gives the same as the ``torquefree_sim`` fixture. The contract: docs/CONTRACT.md, "Test
kit".
"""

from .kit import (
    DEFAULT_TIMEOUT,
    message_stamp_ns,
    Sample,
    Simulator,
    simulator,
    SimulatorTimeout,
    stamp_ns,
    State,
    Tap,
)

__all__ = [
    'DEFAULT_TIMEOUT',
    'Sample',
    'Simulator',
    'SimulatorTimeout',
    'State',
    'Tap',
    'message_stamp_ns',
    'simulator',
    'stamp_ns',
]
