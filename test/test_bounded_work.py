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
Bounded work everywhere.

What the node refuses, the API and the offline tools refuse too, quickly and in our words (found by
fuzzing scenes: integrations that ran forever, overflows, scipy's messages reaching the user);
torquefree_bag stops on the first signal whatever it is computing.
"""

import os
from pathlib import Path
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from torquefree_ros.core.propagators import MAX_STEPS_PER_SAMPLE, StepBudgetExceeded, StepTooSmall
from torquefree_ros.core.scene import scene_from_mapping, SceneError

BIN = Path(sys.prefix) / 'bin'
TIMEOUT = 60  # s, for a console script (its start-up re-executes the interpreter once)


def _scene(omega, effects, orientation=(0.0, 0.0, 0.0, 1.0)):
    return {
        'body': {'inertia': [3.0, 2.0, 1.5]},
        'initial': {'angular_velocity': omega, 'orientation': list(orientation)},
        'effects': effects,
    }


# (scene, the error, words of its message): each was a hang or a foreign message before
HOSTILE = {
    'a rotor scene spinning at 1e29 rad/s': (
        _scene([1.2e29, 0.2, 1.0], [{'rotor': {'momentum': 1.0, 'axis': [0, 0, 1]}}]),
        StepBudgetExceeded,
        f'needs more than {MAX_STEPS_PER_SAMPLE:,} steps',
    ),
    'a torque of 1e300': (
        _scene([0.1, 0.2, 0.3], [{'external_torque': {'torque': [1e300, 0, 0]}}]),
        StepTooSmall,
        'too fast or too stiff for float64 steps, or has overflowed',
    ),
    'a rotor momentum of 1e30': (
        _scene([0.1, 0.2, 0.3], [{'rotor': {'momentum': 1e30, 'axis': [0, 1, 0]}}]),
        RuntimeError,
        'too stiff for an explicit integrator',
    ),
    'a damping of 1e9': (
        _scene([0.1, 0.2, 0.3], [{'damper': {'inertia': 0.1, 'damping': 1e9}}]),
        RuntimeError,
        'too stiff for an explicit integrator',
    ),
}


@pytest.mark.parametrize('case', HOSTILE)
def test_hostile_scenes_end_quickly_in_our_words_through_the_api(case, integrator_path):
    data, error, words = HOSTILE[case]
    propagator = scene_from_mapping(data).propagator()
    calls = [0]
    if integrator_path == 'reference':  # scipy's steps, on our right-hand side: count its calls
        rhs = propagator._rhs

        def counted(t, y):
            calls[0] += 1
            return rhs(t, y)

        propagator._rhs = counted
    started = time.process_time()
    # numpy's default handling of float errors, as a user has it (the reference path's stages
    # overflow)
    with np.errstate(all='ignore'), pytest.raises(error, match=words) as raised:
        propagator(np.arange(0.0, 10.0, 0.01))
    # caught within a sample's step budget (12 right-hand sides a DOP853 step, a few more for the
    # initial step and the dense output), not after ~forever; the compiled path's steps are not
    # counted from Python: a wall guard for both, generous (a loaded machine, coverage's tracing)
    assert calls[0] <= 16 * (MAX_STEPS_PER_SAMPLE + 1), calls[0]
    assert time.process_time() - started < 30.0
    # scipy's own words never reach the user
    assert 'spacing between numbers' not in str(raised.value)


@pytest.mark.parametrize('mean_motion', [1e308, 1e200])
def test_an_effect_parameter_that_overflows_is_refused_at_load_with_its_path(mean_motion):
    data = _scene(
        [0.1, 0.2, 0.3], [{'imu': {}}, {'gravity_gradient': {'mean_motion': mean_motion}}]
    )
    with pytest.raises(
        SceneError,
        match=r"effects\[1\]\.gravity_gradient: its torque or its own state's rate "
        r'overflows float64 at the initial state',
    ):
        scene_from_mapping(data)


def test_an_override_that_makes_an_effect_overflow_is_refused_when_the_propagator_is_built():
    """
    An override that makes an effect overflow is refused when the propagator is built.

    The node's overrides (inertia, angular_velocity) reach the propagator without a scene load.
    """
    # the local vertical off every principal axis
    tilted = (0.2, 0.3, 0.1, float(np.sqrt(1 - 0.14)))
    scene = scene_from_mapping(
        _scene([0.1, 0.2, 0.3], [{'gravity_gradient': {'mean_motion': 1e150}}], tilted)
    )
    # 3 n^2 I: 3e300 N m with the scene's body; the override's 1e10 kg m^2 takes it past 1.8e308
    with pytest.raises(
        ValueError, match=r'^effects: gravity_gradient\(mean_motion=1e\+150.*overflows float64'
    ):
        scene.propagator(inertia=[3e10, 2e10, 1.5e10])


def test_the_bag_tool_ends_on_a_refused_sample_with_a_complete_bag(tmp_path):
    from torquefree_ros.bag import BagReader

    path = tmp_path / 'rotor.yaml'
    path.write_text(
        'body: {inertia: [3.0, 2.0, 1.5]}\ninitial: {angular_velocity: [1.2e29, 0.2, 1.0]}\n'
        'effects:\n  - rotor: {momentum: 1.0, axis: [0, 0, 1]}\n'
    )
    result = subprocess.run(
        [
            str(BIN / 'torquefree_bag'),
            str(path),
            '--duration',
            '10',
            '--rate',
            '100',
            '--output',
            str(tmp_path / 'bag'),
        ],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert result.returncode == 1 and 'Traceback' not in result.stderr, result.stderr
    assert f'needs more than {MAX_STEPS_PER_SAMPLE:,} steps' in result.stderr
    assert 'is a complete bag of the samples before it' in result.stderr
    reader = BagReader(tmp_path / 'bag')
    # sample 0, the initial state, and nothing after
    assert reader.complete and reader.message_count == 2


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGINT], ids=['SIGTERM', 'SIGINT'])
def test_the_bag_tool_stops_on_the_first_signal_even_when_a_sample_takes_long(tmp_path, sig):
    """
    The bag tool stops within about a sample of the first signal, even at 0.5 s a sample.

    The reference path's rk4 at 0.1 Hz: each sample is 10 000 Python steps (~0.5 s); blocks start
    at one sample and grow only while fast, so the first signal is seen within about a sample.
    """
    from torquefree_ros.bag import BagReader

    process = subprocess.Popen(
        [
            str(BIN / 'torquefree_bag'),
            'explorer1',
            '--propagator',
            'rk4',
            '--duration',
            '1e5',
            '--rate',
            '0.1',
            '--output',
            'slow',
        ],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, 'TORQUEFREE_ROS_KERNELS': 'numpy'},
    )
    deadline = time.monotonic() + TIMEOUT
    while not any(tmp_path.rglob('*.mcap')) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.0)  # into the work
    process.send_signal(sig)
    signalled = time.monotonic()
    _, err = process.communicate(timeout=TIMEOUT)
    waited = time.monotonic() - signalled
    assert process.returncode == 130 and 'Traceback' not in err, err
    # a sample or two of ~0.5 s at most (shared machine: 5 s), not a block of thousands of samples
    assert waited < 5.0, waited
    reader = BagReader(tmp_path / 'slow')
    assert reader.complete and reader.message_count >= 2
