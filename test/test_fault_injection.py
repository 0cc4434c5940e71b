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
Faults and sensor noise changed on a running node (the test kit), and their replay from its bag.

A change set with ``set_parameters`` between two samples reaches the next sample exactly; the bag
holds it; ``torquefree_bag --commands BAG`` re-simulates the recording bit for bit. The reference
rows come from the core's ``Simulation`` run offline: the faults' own arithmetic (``raw + step``)
and a sensor built with the new noise from the start, not the node's code path.
"""

from __future__ import annotations

import json

from bag_checks import read_with_rosbags, stamp_ns
from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter as ParameterMessage
from rclpy.parameter import get_parameter_value, Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu
from torquefree_ros.bag import BagReader
from torquefree_ros.cli.bag import main as bag_main
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import load_scene
from torquefree_ros.testing import simulator

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
RATE = 50.0
SCENE = """
body: {inertia: [3.0, 2.0, 1.0]}
initial: {angular_velocity: [0.1, 0.2, 0.3]}
effects:
  - imu: {gyro_noise_density: 0.001, seed: 7}
"""
STEP = [0.25, -0.5, 1.0]  # rad/s


def _scene(tmp_path, text=SCENE, name='scene.yaml'):
    path = tmp_path / name
    path.write_text(text)
    return path


def _rates(messages) -> np.ndarray:
    return np.array([[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z]
                     for m in messages])


def _offline_imu(scene, count: int, faults=()) -> np.ndarray:
    """Return the imu's rows of samples 0 .. count - 1 with ``faults``, from the core."""
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs, faults=faults)
    return simulation.samples(0, count).outputs[0][:, 13:16]


def _set(sim, **values):
    return sim.node.set_parameters_atomically(
        [Parameter(name, value=value) for name, value in values.items()]
    )


def test_a_fault_set_while_running_reaches_the_next_sample_the_bag_and_its_replay(tmp_path):
    # the scene's own spikes (sample 2 on) go on under the bias set while running, listed after
    spikes = '[{spikes: {output: imu, start: 0.04, magnitude: 0.5, probability: 0.5}}]'
    path = _scene(tmp_path, SCENE + f'faults: {spikes}\n')
    bag = tmp_path / 'live'
    first, more = 6, 8
    with simulator(str(path), publish_rate=RATE, record_bag=str(bag)) as sim:
        tap = sim.tap('imu', Imu, RELIABLE)
        sim.advance(first)
        # the window started before now: it starts at the next sample out, sample `first`
        faults = json.dumps([{'bias': {'output': 'imu', 'start': 0.0, 'step': STEP}}])
        result = _set(sim, faults=faults)
        assert result.successful, result.reason
        sim.advance(more)
        tap.wait(first + more)
        received = _rates(tap.messages)
        epoch = sim.samples[0].stamp_ns
    scene = load_scene(path)
    spiked = _offline_imu(scene, first + more, scene.faults)
    assert np.any(spiked != _offline_imu(scene, first + more))  # the scene's spikes are there
    # before the change: the scene's faulted rows, bit for bit; from sample `first` on: + the step
    np.testing.assert_array_equal(received[:first], spiked[:first])
    np.testing.assert_array_equal(received[first:], spiked[first:] + np.array(STEP))

    messages, _ = read_with_rosbags(bag)
    (change,) = messages['/sensor_changes']
    period = round(1e9 / RATE)
    assert change[0] == epoch + first * period  # logged at the stamp of the sample it reached
    assert json.loads(change[1].data) == {'faults': faults, 'sensor_noise': ''}
    recorded = [m.data for m in BagReader(bag).messages(['/imu'])]
    assert len(recorded) >= first + more
    # re-simulated offline from the bag: the faulted imu comes out bit for bit
    replay = tmp_path / 'replay'
    code = bag_main([
        str(path), '--commands', str(bag), '--rate', str(RATE), '--output', str(replay),
        '--duration', str((first + more - 1) / RATE), '--start-time', f'{epoch / 1e9:.9f}',
    ])
    assert code == 0
    replayed = [m.data for m in BagReader(replay).messages(['/imu'])]
    assert replayed == recorded[: first + more]
    assert [m.data for m in BagReader(replay).messages(['/sensor_changes'])] == [
        m.data for m in BagReader(bag).messages(['/sensor_changes'])
    ]
    assert stamp_ns(messages['/imu'][first][1].header) == change[0]


def test_a_dropout_set_while_running_publishes_nothing_in_its_window(tmp_path):
    path = _scene(tmp_path)
    with simulator(str(path), publish_rate=RATE) as sim:
        tap = sim.tap('imu', Imu, RELIABLE)
        sim.advance(2)
        # samples 4, 5, 6 (t = 0.08 .. 0.12 s at 50 Hz) carry no imu message
        faults = '[{dropout: {output: imu, start: 0.08, end: 0.14}}]'
        assert _set(sim, faults=faults).successful
        samples = sim.advance(8)
        stamps = [stamp_ns(m.header) for m in tap.wait(7)]
        diagnostics = sim.node.sample_loop.simulation.fault_diagnostics(5)
    expected = [s.stamp_ns for s in sim.samples[:10] if s.index not in (4, 5, 6)]
    assert stamps == expected and len(samples) == 8
    assert diagnostics == {'faults': '1', 'faults_active': 'dropout imu [0.08, 0.14) s no message'}


def test_sensor_noise_changed_while_running_is_the_rebuilt_sensor_from_the_next_sample(tmp_path):
    path = _scene(tmp_path)
    bag = tmp_path / 'live'
    first, more = 5, 6
    with simulator(str(path), publish_rate=RATE, record_bag=str(bag)) as sim:
        tap = sim.tap('imu', Imu, RELIABLE)
        sim.advance(first)
        assert _set(sim, sensor_noise='{imu: {gyro_noise_density: 0.05}}').successful
        sim.advance(more)
        received = _rates(tap.wait(first + more))
        epoch = sim.samples[0].stamp_ns
    scene = load_scene(path)
    louder_text = SCENE.replace('gyro_noise_density: 0.001', 'gyro_noise_density: 0.05')
    louder = load_scene(_scene(tmp_path, louder_text, 'louder.yaml'))
    np.testing.assert_array_equal(received[:first], _offline_imu(scene, first))
    # the same seed: the same normals, scaled by the new density from sample `first` on
    np.testing.assert_array_equal(
        received[first:], _offline_imu(louder, first + more)[first:]
    )
    # the bag holds the change; the offline replay of the scene under it gives the same bytes
    replay = tmp_path / 'replay'
    assert bag_main([
        str(path), '--commands', str(bag), '--rate', str(RATE), '--output', str(replay),
        '--duration', str((first + more - 1) / RATE), '--start-time', f'{epoch / 1e9:.9f}',
    ]) == 0
    recorded = [m.data for m in BagReader(bag).messages(['/imu'])][: first + more]
    assert [m.data for m in BagReader(replay).messages(['/imu'])] == recorded


def test_ros2_param_set_s_own_parsing_reaches_the_node_and_diagnostics_show_the_active_fault(
    tmp_path,
):
    # `ros2 param set NODE faults TEXT` sends what rclpy's get_parameter_value makes of TEXT: a
    # list of mappings stays the text (a string parameter), "[]" becomes an empty array
    scene = SCENE + 'faults: [{bias: {output: imu, start: 0.0, end: 0.04, step: [1, 1, 1]}}]\n'
    with simulator(str(_scene(tmp_path, scene)), publish_rate=RATE) as sim:
        diagnostics = sim.tap('/diagnostics', DiagnosticArray, RELIABLE)
        sim.advance(1)
        text = '[{stuck: {output: imu, start: 0.0}}]'
        (result,) = sim.node.set_parameters(
            [Parameter.from_parameter_msg(
                ParameterMessage(name='faults', value=get_parameter_value(text)))]
        )
        assert result.successful, result.reason
        sim.advance(2)

        def reported():
            return [
                {v.key: v.value for v in status.values}
                for array in diagnostics.messages
                for status in array.status
                if any(v.key == 'faults_active' for v in status.values)
            ]

        sim.spin_until(lambda: any(r['faults_active'].startswith('stuck') for r in reported()))
        latest = [r for r in reported() if r['faults_active'].startswith('stuck')][-1]
        # at sample 2 the scene's bias (samples 0, 1) is over and the parameter's stuck acts
        assert latest['faults'] == '2'
        assert latest['faults_active'] == 'stuck imu [0, ...) s at the last value'
        (cleared,) = sim.node.set_parameters(
            [Parameter.from_parameter_msg(
                ParameterMessage(name='faults', value=get_parameter_value('[]')))]
        )
        assert cleared.successful, cleared.reason
        assert [f.kind for f in sim.node.sample_loop.simulation.faults] == ['bias']


@pytest.mark.parametrize(
    'name, value, path',
    [
        ('faults', '[{bias: {output: imu, start: 1.0, end: 0.5, step: [0, 0, 0]}}]',
         'faults[0].bias.end'),
        ('faults', '[{bias: {output: gyro, start: 1.0, step: [0, 0, 0]}}]',
         'faults[0].bias.output'),
        ('faults', '[{spikes: {output: imu, start: 0, magnitude: -1, period: 1}}]',
         'faults[0].spikes.magnitude'),
        ('faults', '[{noise: {output: imu, start: 0, sigma: .nan}}]', 'faults[0].noise.sigma'),
        ('faults', '[{stuck: {output: imu, start: [}', 'faults:1:'),
        ('sensor_noise', '{imu: {seed: 3}}', 'sensor_noise.imu.seed'),
        ('sensor_noise', '{imu: {gyro_noise_density: -1}}', 'sensor_noise.imu.gyro_noise_density'),
        ('faults', 7, 'faults: expected a string'),
    ],
)
def test_bad_changes_are_refused_with_the_field_path_and_the_run_goes_on(
    tmp_path, name, value, path
):
    with simulator(str(_scene(tmp_path)), publish_rate=RATE) as sim:
        sim.advance(2)
        simulation = sim.node.sample_loop.simulation
        before = (simulation.faults, simulation.outputs)
        result = _set(sim, **{name: value})
        assert not result.successful and result.reason.startswith(path), result.reason
        assert (simulation.faults, simulation.outputs) == before
        assert sim.node.sample_loop.simulation is simulation
        assert [s.index for s in sim.advance(2)] == [2, 3]


def test_faults_that_fit_only_the_next_reset_s_scene_wait_for_it(tmp_path):
    with simulator(str(_scene(tmp_path)), publish_rate=RATE) as sim:
        sim.advance(1)
        assert _set(sim, scene='estimator').successful  # for the next ~/reset
        faults = '[{dropout: {output: star_tracker, start: 0.0}}]'
        # the running scene has no star tracker: not applied now, nor refused
        assert _set(sim, faults=faults).successful
        assert sim.node.sample_loop.simulation.faults == ()
        sim.reset()
        (fault,) = sim.node.sample_loop.simulation.faults
        assert (fault.kind, fault.output) == ('dropout', 'star_tracker')
        # and a list that fits neither scene is refused, naming its path
        result = _set(sim, faults='[{dropout: {output: sun_sensor, start: 0.0}}]')
        assert not result.successful and result.reason.startswith('faults[0].dropout.output')
