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
The magnetometer one sample at a time (a closed loop's lock-step) against its block path (#41).

A sample alone takes its own path: the orbit's position and the field in one compiled call
(``Place.position_and_field``; with the samples in order, ``Place.field_values``, those of the
next 64 samples in one call, kept), the errors on Python floats. The reference is the block path of
the same code base (``Place.state`` and ``Place.field_N`` over many instants, the errors on numpy
arrays), which the field's own tests hold to ppigrf (``test_orbit_effects``); the contract is the
same bytes whichever way the samples are asked for, so the comparisons are exact.
"""

from __future__ import annotations

from conftest import require_numba
import numpy as np
import pytest
from test_orbit_effects import ISS_TLE, LEO, scene
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.effects import sensors
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.run.simulation import Simulation

NT = 1e-9
#: every error term of the magnetometer at once (its quantization of 1 nT keeps most bits)
FULL = {
    'noise': 50 * NT,
    'bias': [120 * NT, -300 * NT, 45 * NT],
    'scale_factor': [150.0, -90.0, 400.0],
    'misalignment': [[0.0, 25.0, -40.0], [60.0, 0.0, 15.0], [-30.0, 8.0, 0.0]],
    'saturation': 60000 * NT,
    'quantization': 0.001 * NT,
    'seed': 17,
}
#: the same without quantization, which would hide a difference of an ulp in most samples
UNQUANTIZED = {key: value for key, value in FULL.items() if key != 'quantization'}
#: no noise: a sample needs no normals, but with a -0.0 in the bias (which the zero noise would
#: turn to +0.0 on a zero reading) it draws them as the block does
NOISELESS = {key: value for key, value in FULL.items() if key != 'noise'}
NEGATIVE_ZERO = {**UNQUANTIZED, 'noise': 0.0, 'bias': [-0.0, 120 * NT, 0.0]}
COUNT = 150  # samples: past the 64 drawn ahead at a time, twice


@pytest.fixture(params=[True, False], ids=['kernels', 'numpy'])
def kernels(request, monkeypatch):
    """Run a test with the compiled kernels and with numpy's reference path."""
    if request.param and not switch.AVAILABLE:
        require_numba()
    monkeypatch.setattr(switch, 'ENABLED', request.param)
    # environment_at keeps the last values asked for by place (equal places: equal orbits), so
    # a scene of the other path's test would read those
    monkeypatch.setattr(sensors._LAST_ENVIRONMENT, 'key', None)
    return request.param


@pytest.mark.parametrize('orbit', [LEO, {**LEO, 'j2': True}, {'tle': ISS_TLE}],
                         ids=['kepler', 'j2', 'tle'])
@pytest.mark.parametrize('model', ['igrf', 'dipole'])
def test_the_position_and_field_of_one_instant_are_the_block_s_bytes(kernels, orbit, model):
    place = scene([], orbit=orbit).orbit
    times = np.linspace(0.0, 5400.0, 41) + 0.1  # a whole orbit, instants of no special form
    position = place.state(times)[0]
    field = place.field_N(times, position, model)
    for k, t in enumerate(times):
        one_position, one_field = place.position_and_field(float(t), model)
        assert one_position.tobytes() == position[k: k + 1].tobytes(), (model, t)
        assert one_field.tobytes() == field[k: k + 1].tobytes(), (model, t)
        assert not (one_position.flags.writeable or one_field.flags.writeable)  # kept, shared
    # a sensor's samples at 0.3 Hz, computed 64 at a time: over two sets, each sample's own
    samples = np.arange(150) / 0.3
    position = place.state(samples)[0]
    field = place.field_N(samples, position, model)
    for k, t in enumerate(samples.tolist()):
        assert place.field_values(t, model, k, 0.3) == field[k].tolist(), (model, t)
        # what the sensor kept: read at the same instants by the one-instant path
        one_position, one_field = place.position_and_field(t, model)
        assert one_position.tobytes() == position[k: k + 1].tobytes(), (model, t)
        assert one_field.tobytes() == field[k: k + 1].tobytes(), (model, t)


def test_an_instant_outside_the_field_model_s_years_is_refused_naming_the_orbit(kernels):
    place = scene([], orbit=LEO).orbit
    for t in (1e10, float('nan')):
        with pytest.raises(FieldError, match=r'^orbit: '):
            place.position_and_field(t, 'igrf')


def _lockstep(s, rate: float, firsts) -> np.ndarray:
    """Return the magnetometer's rows asked for one sample at a time, at ``firsts``."""
    simulation = Simulation(s.propagator(), rate, outputs=s.outputs)
    return np.vstack([simulation.samples(k, 1).outputs[0] for k in firsts])


@pytest.mark.parametrize('model', ['igrf', 'dipole'])
@pytest.mark.parametrize('parameters', [FULL, {}, UNQUANTIZED, NOISELESS, NEGATIVE_ZERO],
                         ids=['every error', 'exact', 'unquantized', 'noiseless', '-0.0 bias'])
def test_one_sample_at_a_time_reads_the_block_s_bytes(kernels, model, parameters):
    s = scene([{'magnetometer': {**parameters, 'field': model}}], omega=(0.3, -0.2, 0.4))
    block = Simulation(s.propagator(), 2.0, outputs=s.outputs).samples(0, COUNT).outputs[0]
    assert np.unique(block[:, 0:3], axis=0).shape[0] == COUNT  # every reading its own
    in_order = _lockstep(s, 2.0, range(COUNT))
    assert in_order.tobytes() == block.tobytes()
    # a skip forward draws the skipped samples' noise, a skip back starts the draws over
    jumps = [0, 1, 5, 70, 71, 3, 140, 2]
    assert _lockstep(s, 2.0, jumps).tobytes() == block[jumps].tobytes()


def test_an_own_rate_and_the_end_of_the_model_s_years_read_the_block_s_bytes(kernels):
    """
    The samples computed ahead are only used at their own instants.

    An output at a quarter of the simulation's rate (its instants ``4 j / 2`` Hz, not ``j /
    0.5``), and an orbit whose field model ends within the samples computed ahead: the samples
    before the end read as the block, the first past it is refused naming the orbit.
    """
    s = scene([{'magnetometer': {**FULL, 'rate': 0.5}}], omega=(0.3, -0.2, 0.4))
    block = Simulation(s.propagator(), 2.0, outputs=s.outputs).samples(0, 4 * 70)
    assert _lockstep(s, 2.0, range(4 * 70)).tobytes() == block.outputs[0].tobytes()
    late = scene([{'magnetometer': FULL}], orbit={**LEO, 'start': '2029-12-31T23:59:00Z'})
    simulation = Simulation(late.propagator(), 1.0, outputs=late.outputs)
    rows = np.vstack([simulation.samples(k, 1).outputs[0] for k in range(60)])
    offline = Simulation(late.propagator(), 1.0, outputs=late.outputs).samples(0, 60)
    assert rows.tobytes() == offline.outputs[0].tobytes()
    with pytest.raises(FieldError, match=r'^orbit: IGRF-14 covers'):
        late.orbit.field_values(61.0, 'igrf', 61, 1.0)


@pytest.mark.parametrize('model', ['igrf', 'dipole'])
def test_the_environment_of_one_sample_is_the_block_s_beside_the_other_sensors(kernels, model):
    """
    Beside a sun sensor, each sensor reads the block's bytes; ``environment_at`` one sample.

    ``environment_at`` (the batched sensors' path, ``Plant.sensors()``) takes the field of one
    sample and its position in one call: the floats of ``Place.state`` and ``Place.field_N``.
    """
    s = scene([{'magnetometer': {'field': model}}, {'sun_sensor': {'noise': 0.1, 'seed': 3}}])
    block = Simulation(s.propagator(), 2.0, outputs=s.outputs).samples(0, 40)
    lockstep = Simulation(s.propagator(), 2.0, outputs=s.outputs)
    for k in range(40):
        outputs = lockstep.samples(k, 1).outputs
        for position in range(2):
            assert outputs[position].tobytes() == block.outputs[position][k: k + 1].tobytes()
        times = np.array([k / 2.0 + 0.25])  # an instant no sensor asked for: a new evaluation
        field = sensors.environment_at(s.orbit, times, model)
        position = s.orbit.state(times)[0]
        assert field.tobytes() == s.orbit.field_N(times, position, model).tobytes()
        assert sensors.environment_at(s.orbit, times, 'position').tobytes() == position.tobytes()
