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
The whole cost of one sample after the propagator, for the default scene at 100 Hz.

CDR encoding, the node's publishes, bag writing (offline, in blocks; the node's recorder, one
sample at a time), and the offline bag throughput, all measured in one process.
"""

from __future__ import annotations

from pathlib import Path
import tempfile
import time

RATE = 100.0
_BLOCK = 256  # samples per block, as the node's loop


def sample_costs(samples: int = 20000) -> dict:
    """µs per sample of each stage (a sample = angular_velocity + attitude + /clock)."""
    from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
    import rclpy
    from rosgraph_msgs.msg import Clock

    from ..bag import BagWriter
    from ..bag.cdr import encode_times
    from ..bag.samples import encode_block, SampleRecorder
    from ..core.scene.loader import default_scene
    from ..core.run.simulation import Simulation

    simulation = Simulation(default_scene().propagator(), RATE)
    t0 = time.process_time()
    blocks = [
        simulation.samples(first, min(_BLOCK, samples - first))
        for first in range(0, samples, _BLOCK)
    ]
    t1 = time.process_time()
    encoded = [
        (b.stamps_ns, encode_block(b, 'body', 'world'), encode_times(b.stamps_ns)) for b in blocks
    ]
    t2 = time.process_time()
    costs = {'propagate (exact)': t1 - t0, 'CDR encoding': t2 - t1}

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node('bench_publish', context=context)
        publishers = (
            node.create_publisher(Clock, '/clock', 10),
            node.create_publisher(Vector3Stamped, 'angular_velocity', 10),
            node.create_publisher(QuaternionStamped, 'attitude', 10),
        )
        t3 = time.process_time()
        for _, columns, clocks in encoded:
            omegas, qs = (column.messages for column in columns)
            for i in range(len(clocks)):
                publishers[0].publish(clocks[i])
                publishers[1].publish(omegas[i])
                publishers[2].publish(qs[i])
        costs['node publishes (3 raw, no subscriber)'] = time.process_time() - t3
        node.destroy_node()
    finally:
        context.try_shutdown()

    with tempfile.TemporaryDirectory() as tmp:
        with BagWriter(Path(tmp) / 'blocks') as writer:
            recorder = SampleRecorder.in_namespace(writer)
            t4 = time.process_time()
            for stamps, columns, _ in encoded:
                recorder.write_block(stamps, columns)
            costs['bag write, offline blocks'] = time.process_time() - t4
        with BagWriter(Path(tmp) / 'samples') as writer:
            recorder = SampleRecorder.in_namespace(writer)
            t5 = time.process_time()
            for stamps, columns, _ in encoded:
                for i in range(len(stamps)):
                    recorder.write_sample(int(stamps[i]), columns, i)
            costs['bag write, node recorder (per sample)'] = time.process_time() - t5
    return {stage: seconds / samples * 1e6 for stage, seconds in costs.items()}
