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
        estimator = MyEstimator(context=sim.context)
        sim.add_node(estimator)
        sim.advance(100)            # 100 samples out, each processed by every node added
        truth = sim.truth(sim.t)    # the exact state at the last sample's time

Each simulator has a ROS domain of its own, so its node publishes in the root namespace
(``/angular_velocity``, ...) and a node made without a namespace finds its topics; ``namespace=``
puts it in one (several simulators in one domain), and then the nodes added go there too
(``namespace=sim.namespace``).

The pytest plugin (``torquefree_ros.testing.pytest_plugin``, registered as a ``pytest11`` entry
point) gives the same as the ``torquefree_sim`` fixture. The contract: docs/CONTRACT.md, "Test
kit". The modules: ``kit`` (the simulator's life and stepping), ``delivery`` (what the nodes added
processed), ``failures`` (what a failure says), ``truth`` (the run followed: samples, truth,
reset), ``samples`` (the values handed out), ``domains`` (a ROS domain per simulator).
"""

from .failures import SimulatorTimeout
from .kit import DEFAULT_TIMEOUT, Simulator, simulator, Tap
from .samples import message_stamp_ns, Sample, stamp_ns, State

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
