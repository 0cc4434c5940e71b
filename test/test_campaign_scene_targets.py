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
Campaigns that reach into the scene beyond the body (issues 40, 41, 42).

A metric with a column per reaction wheel against the plant's wheel speeds; the orbit's Keplerian
elements dispersed by path (each run's orbit is the orbit of a scene written with the drawn
elements, bit for bit; the draws have the declared statistics; an element that makes no orbit is
a run ``invalid_scene`` naming the element; a TLE is refused); sensor parameters and fault fields
dispersed by path, checked in each run's scene, and a run's scene written out as YAML is the scene
the run ran.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from torquefree_ros import Plant
from torquefree_ros.campaigns import CampaignError, load_campaign, run_campaign, run_scene
from torquefree_ros.campaigns.dispersions import run_generator
from torquefree_ros.core.scene.loader import load_scene, scene_from_mapping, SceneError
import yaml

ELEMENTS = (
    'semi_major_axis',
    'eccentricity',
    'inclination',
    'raan',
    'argument_of_perigee',
    'mean_anomaly',
)
# a 400 km orbit, slightly eccentric, every element given
ORBIT = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6778137.0,
    'eccentricity': 0.001,
    'inclination': 0.9,
    'raan': 0.3,
    'argument_of_perigee': 1.1,
    'mean_anomaly': 0.2,
}
ISS_TLE = [
    '1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927',
    '2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537',
]


def orbit_scene(effects, orbit=None):
    """Return a gravity-gradient satellite on ``orbit`` (default ORBIT) with ``effects`` after."""
    return {
        'body': {'inertia': [30.0, 40.0, 20.0]},
        'initial': {
            'angular_velocity': [0.0, -0.0011, 0.0002],
            'orientation': [0.1, -0.2, 0.3, math.sqrt(1.0 - 0.14)],
        },
        'orbit': dict(ORBIT if orbit is None else orbit),
        'effects': effects,
        'accuracy': 1e-10,
    }


def campaign(scene, dispersions, runs=4, metrics=('final_rates',), duration=60.0, **more):
    return {
        'scene': scene,
        'runs': runs,
        'seed': 41,
        'duration': duration,
        'rate': 1.0,
        'dispersions': dispersions,
        'metrics': list(metrics),
        **more,
    }


# -- a peak per wheel -----------------------------------------------------------------------------
def wheel_scene():
    axes = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0])
    return {
        'body': {'inertia': [12.0, 10.0, 8.0]},
        'initial': {'angular_velocity': [0.01, -0.02, 0.03]},
        'effects': [
            {
                'reaction_wheels': {
                    # wheel 2 spins up, then down through zero: its peak is not its last value
                    'schedule': [
                        {'start': 0.0, 'torque': [0.01, -0.02, 0.02, 0.005]},
                        {'start': 6.0, 'torque': [-0.01, 0.02, -0.02, 0.0]},
                    ],
                    'wheels': [
                        {
                            'name': name,
                            'axis': axis,
                            'spin_inertia': 0.01,
                            'max_torque': 0.02,
                            'max_speed': 100.0,
                            'viscous': 1e-5,
                            'coulomb': 5e-4,
                            'speed': speed,
                        }
                        for name, axis, speed in zip(
                            ('x', 'y', 'z', 'skew'), axes, (5.0, 0.0, -3.0, 1.0)
                        )
                    ],
                }
            }
        ],
        'accuracy': 1e-10,
    }


def test_wheel_momentum_peak_has_a_column_per_wheel_against_the_plants_wheel_speeds():
    """
    Each wheel's column is ``max_k |Js_i Omega_i|`` of the plant's wheel speeds in the run's scene.

    The run's scene (its dispersed spin inertia) is run through the plant on its own; the metric
    reads the same state through ``ReactionWheels.wheel_speeds``, so they agree to rounding
    (1e-12 relative). Independently of the plant, the array's stored momentum is at most the sum of
    the wheels' peaks (the triangle inequality at every sample).
    """
    data = {
        'scene': wheel_scene(),
        'runs': 3,
        'seed': 40,
        'duration': 12.0,
        'rate': 10.0,
        'dispersions': {
            'effects[0].reaction_wheels.wheels[1].spin_inertia': {
                'relative': {'normal': {'sigma': 0.1}}
            }
        },
        'metrics': ['momentum_peak', 'wheel_momentum_peak'],
    }
    table = run_campaign(data, scheduler='in-process')
    names = [f'wheel_momentum_peak[{name}]' for name in ('x', 'y', 'z', 'skew')]
    assert table.column_names[-4:] == names
    for run, row in enumerate(table.to_pylist()):
        assert row['status'] == 'ok'
        mapping = run_scene(data, run)
        plant = Plant(scene_from_mapping(mapping), 10.0)
        speeds = np.concatenate([plant.state.wheel_speeds[None], plant.run(12.0).wheel_speeds])
        spin = np.array([wheel['spin_inertia'] for wheel in
                         mapping['effects'][0]['reaction_wheels']['wheels']])
        assert spin[1] == row['effects[0].reaction_wheels.wheels[1].spin_inertia'] != 0.01
        peaks = np.abs(spin * speeds).max(axis=0)
        for column, peak in zip(names, peaks):
            assert row[column] == pytest.approx(peak, rel=1e-12)
        # wheel y reverses: its peak is inside the run, not at its end
        assert peaks[1] > abs(spin[1] * speeds[-1, 1]) * 1.5
        assert row['momentum_peak'] <= sum(row[c] for c in names) * (1.0 + 1e-12)


def test_wheels_of_two_effects_named_alike_are_told_apart_by_their_effect():
    """
    Two ``reaction_wheels`` effects that both name wheels ``x`` and ``y``: ``NAME#m`` columns.

    ``m`` is the motion effect's index; the columns follow the plant's wheel order (every effect's
    wheels in scene order), each its wheel's peak (1e-12 relative, rounding).
    """
    scene = wheel_scene()
    second = copy.deepcopy(scene['effects'][0]['reaction_wheels'])
    second['wheels'] = second['wheels'][:2]
    second['wheels'][0]['speed'] = -8.0  # rad/s: not the first effect's x wheel
    second['schedule'] = [{'start': 0.0, 'torque': [0.01, -0.01]}]
    scene['effects'].append({'reaction_wheels': second})
    data = {'scene': scene, 'runs': 1, 'seed': 0, 'duration': 2.0, 'rate': 10.0,
            'metrics': ['wheel_momentum_peak']}
    row = run_campaign(data, scheduler='in-process').to_pylist()[0]
    labels = ('x#0', 'y#0', 'z', 'skew', 'x#1', 'y#1')
    assert [c for c in row if c.startswith('wheel_')] == [
        f'wheel_momentum_peak[{label}]' for label in labels
    ]
    plant = Plant(scene_from_mapping(scene), 10.0)
    speeds = np.concatenate([plant.state.wheel_speeds[None], plant.run(2.0).wheel_speeds])
    peaks = np.abs(0.01 * speeds).max(axis=0)
    for label, peak in zip(labels, peaks):
        assert row[f'wheel_momentum_peak[{label}]'] == pytest.approx(peak, rel=1e-12)
    assert peaks[4] != peaks[0]  # the two x wheels are different wheels


def test_wheel_momentum_peak_is_refused_for_a_scene_without_wheels():
    data = campaign('dzhanibekov', {}, metrics=('wheel_momentum_peak',))
    with pytest.raises(CampaignError, match=(
        r'metrics\[0\]: wheel_momentum_peak: the scene has no reaction wheels'
    )):
        load_campaign(data)


# -- orbit elements -------------------------------------------------------------------------------
ORBIT_DISPERSIONS = {
    'orbit.semi_major_axis': {'absolute': {'normal': {'sigma': 2000.0}}},  # m
    'orbit.eccentricity': {'absolute': {'truncated_normal': {'sigma': 5e-4, 'low': -1e-3,
                                                             'high': 1e-3}}},
    'orbit.inclination': {'absolute': {'normal': {'sigma': 0.01}}},  # rad, as the scene writes
    'orbit.raan': {'absolute': {'uniform': {'low': -0.5, 'high': 0.5}}},
    'orbit.argument_of_perigee': {'relative': {'normal': {'sigma': 0.1}}},
    'orbit.mean_anomaly': {'replace': {'uniform': {'low': 0.0, 'high': 2.0 * math.pi}}},
}


def test_dispersed_orbit_is_the_orbit_of_a_scene_written_with_its_elements():
    """
    Each run's orbit, and the motion gravity gradient gives on it, are a hand-written scene's.

    The scene is written from the table's drawn elements (the epoch kept); its orbit compares
    equal, its positions over the run are the same floats (``array_equal``), and the plant run on
    it ends with the table's final rates exactly: the dispersion changes nothing but the numbers.
    """
    data = campaign(orbit_scene([{'gravity_gradient': {}}]), ORBIT_DISPERSIONS, runs=3)
    table = run_campaign(data, scheduler='in-process').to_pylist()
    times = np.linspace(0.0, 6000.0, 101)
    for run, row in enumerate(table):
        assert row['status'] == 'ok'
        written = orbit_scene(
            [{'gravity_gradient': {}}],
            {'epoch': ORBIT['epoch'], **{key: row[f'orbit.{key}'] for key in ELEMENTS}},
        )
        expected = scene_from_mapping(written)
        ran = scene_from_mapping(run_scene(data, run))
        assert ran.orbit == expected.orbit
        for element in ELEMENTS:
            assert getattr(ran.orbit.orbit, element) == row[f'orbit.{element}'] != ORBIT[element]
        assert np.array_equal(ran.orbit.state(times)[0], expected.orbit.state(times)[0])
        plant = Plant(expected, 1.0)
        final = plant.run(60.0).omega_B[-1]
        assert final.tolist() == [row['final_wx'], row['final_wy'], row['final_wz']]


def test_orbit_element_draws_have_the_declared_statistics():
    """
    2 000 draws of each element against its declared distribution.

    Normal: the mean within 5 standard errors (sigma / sqrt(N): 2.2 % of sigma) and the standard
    deviation within 5 of its standard errors (sigma / sqrt(2 N): 1.6 %); uniform: the mean within
    5 standard errors (width / sqrt(12 N)) and every draw inside the bounds; truncated normal:
    every draw inside its bounds (so the eccentricity stays in [0, 1)), symmetric about the nominal
    (mean within 5 standard errors, the truncated deviation 0.88 sigma at +-2 sigma bounding it).
    A draw depends only on (seed, run).
    """
    draws = 2000
    loaded = load_campaign(campaign(orbit_scene([]), ORBIT_DISPERSIONS, runs=draws))
    values = {target.element: np.array([
        target.draw(run_generator(loaded.seed, i), i)[0] for i in range(draws)
    ]) for target in loaded.targets}
    root = math.sqrt(draws)

    def normal(x, mean, sigma):
        assert abs(x.mean() - mean) < 5 * sigma / root
        assert abs(x.std(ddof=1) - sigma) < 5 * sigma / math.sqrt(2 * draws)

    normal(values['semi_major_axis'], ORBIT['semi_major_axis'], 2000.0)
    normal(values['inclination'], ORBIT['inclination'], 0.01)
    normal(values['argument_of_perigee'], ORBIT['argument_of_perigee'],
           0.1 * ORBIT['argument_of_perigee'])
    raan = values['raan']
    assert raan.min() >= ORBIT['raan'] - 0.5 and raan.max() <= ORBIT['raan'] + 0.5
    assert abs(raan.mean() - ORBIT['raan']) < 5 * 1.0 / math.sqrt(12 * draws)
    anomaly = values['mean_anomaly']
    assert anomaly.min() >= 0.0 and anomaly.max() <= 2.0 * math.pi
    assert abs(anomaly.mean() - math.pi) < 5 * 2.0 * math.pi / math.sqrt(12 * draws)
    e = values['eccentricity']
    assert e.min() >= 0.0 and e.max() <= 0.002
    assert abs(e.mean() - ORBIT['eccentricity']) < 5 * 5e-4 / root
    assert e.std() < 5e-4
    again = load_campaign(campaign(orbit_scene([]), ORBIT_DISPERSIONS, runs=draws))
    target = again.targets[0]
    assert target.draw(run_generator(41, 7), 7)[0] == values[target.element][7]


@pytest.mark.parametrize(
    'dispersion, reason',
    [
        (  # run 1: a perigee 6 100 km from the centre, under the surface
            {'orbit.eccentricity': {'replace': {'values': [0.001, 0.1]}}},
            'orbit.eccentricity: the perigee radius a (1 - e) = 6.10032e+06 m is inside the Earth',
        ),
        (
            {'orbit.eccentricity': {'replace': {'values': [0.001, 1.0]}}},
            'orbit.eccentricity: must be < 1',
        ),
        (
            {'orbit.eccentricity': {'replace': {'values': [0.001, -0.01]}}},
            'orbit.eccentricity: must be >= 0',
        ),
        (
            {'orbit.semi_major_axis': {'absolute': {'values': [0.0, -500000.0]}}},
            "orbit.semi_major_axis: must be above the Earth's equatorial radius",
        ),
        (
            {'orbit.inclination': {'replace': {'values': [0.5, 4.0]}}},
            'orbit.inclination: must be <= 3.14159',
        ),
    ],
)
def test_an_element_that_makes_no_orbit_fails_its_run_naming_the_element(dispersion, reason):
    """
    Run 1 draws an orbit the scene's checks refuse: a row ``invalid_scene`` with the field.

    The scene has no motion effect (a magnetometer only), so its runs are torque-free: their
    scenes are built and checked all the same. Run 0 is fine and runs; ``run_scene`` gives run 1's
    scene as drawn, which the loader refuses for the row's reason.
    """
    data = campaign(orbit_scene([{'magnetometer': {}}]), dispersion, runs=2)
    rows = run_campaign(data, scheduler='in-process').to_pylist()
    assert rows[0]['status'] == 'ok' and rows[0]['reason'] is None
    assert rows[1]['status'] == 'invalid_scene'
    assert rows[1]['reason'].startswith(reason), rows[1]['reason']
    assert rows[1]['final_wx'] is None
    # the run's scene, written as drawn, is refused with the same reason when loaded
    with pytest.raises(SceneError) as error:
        scene_from_mapping(run_scene(data, 1), source='run 1')
    assert str(error.value) == f'run 1: {rows[1]["reason"]}'


@pytest.mark.parametrize(
    'orbit, key, message',
    [
        ({'tle': ISS_TLE}, 'orbit.eccentricity',
         "dispersions.orbit.eccentricity: the scene's orbit is a two-line element set"),
        ({'tle': ISS_TLE}, 'orbit.tle', 'two-line element set'),
        (ORBIT, 'orbit.epoch', 'dispersions.orbit.epoch: orbit.epoch is an instant'),
        (ORBIT, 'orbit.j2', 'dispersions.orbit.j2: orbit.j2 is a switch'),
        (ORBIT, 'orbit.eccentricty', "no element 'eccentricty'; did you mean 'eccentricity'"),
        (None, 'orbit.raan', 'dispersions.orbit.raan: outside the scene: it has no orbit'),
    ],
)
def test_orbit_targets_outside_the_dispersible_elements_are_refused(orbit, key, message):
    scene = orbit_scene([{'magnetometer': {}}], orbit)
    if orbit is None:
        scene = {k: v for k, v in scene.items() if k != 'orbit'}
        scene['effects'] = []
    data = campaign(scene, {key: {'absolute': {'normal': {'sigma': 0.01}}}})
    with pytest.raises(CampaignError) as error:
        load_campaign(data)
    assert message in str(error.value)


# -- sensor parameters and faults -----------------------------------------------------------------
SENSORS = [
    {'gravity_gradient': {}},
    {'magnetometer': {'noise': 1e-7, 'bias': [1e-7, 0.0, -1e-7], 'seed': 3}},
    {'imu': {'gyro_noise_density': 1e-4, 'seed': 5}},
]
FAULTS = [
    {'bias': {'output': 'magnetometer', 'start': 20.0, 'end': 40.0, 'step': [1e-6, 0.0, 0.0]}},
    {'noise': {'output': 'imu', 'start': 10.0, 'sigma': 1e-3}},
]
SENSOR_DISPERSIONS = {
    'effects[1].magnetometer.noise': {'relative': {'uniform': {'low': -0.5, 'high': 0.5}}},
    'effects[1].magnetometer.bias': {'direction': {'cone': {'half_angle': 0.3}}},
    'effects[2].imu.gyro_noise_density': {'relative': {'normal': {'sigma': 0.2}}},
    'faults[0].bias.start': {'absolute': {'uniform': {'low': -5.0, 'high': 5.0}}},
    'faults[1].noise.sigma': {'relative': {'normal': {'sigma': 0.1}}},
    'orbit.raan': {'absolute': {'normal': {'sigma': 0.1}}},
}


def sensor_campaign(runs=3):
    scene = orbit_scene(copy.deepcopy(SENSORS))
    scene['faults'] = copy.deepcopy(FAULTS)
    return campaign(scene, SENSOR_DISPERSIONS, runs=runs)


def test_a_runs_scene_written_out_is_the_scene_it_ran(tmp_path):
    """
    ``run_scene`` written as YAML and loaded is the run's scene: equal outputs, faults and orbit.

    The drawn sensor parameters and fault fields are in it as drawn (the same floats); the plant
    run on the loaded file ends with the table's final rates exactly (the outputs change no
    motion; the orbit's RAAN does, through gravity gradient).
    """
    data = sensor_campaign()
    rows = run_campaign(data, scheduler='in-process').to_pylist()
    for run, row in enumerate(rows):
        assert row['status'] == 'ok'
        path = tmp_path / f'run{run}.yaml'
        path.write_text(yaml.safe_dump(run_scene(data, run), sort_keys=False))
        loaded = load_scene(str(path))
        magnetometer, imu = loaded.outputs
        assert magnetometer.values['noise'] == row['effects[1].magnetometer.noise'] != 1e-7
        assert list(magnetometer.values['bias']) == [
            row[f'effects[1].magnetometer.bias[{k}]'] for k in range(3)
        ]
        assert imu.values['gyro_noise_density'] == row['effects[2].imu.gyro_noise_density']
        assert loaded.faults[0].start == row['faults[0].bias.start'] != 20.0
        assert loaded.faults[1].sigma == row['faults[1].noise.sigma'] != 1e-3
        assert loaded.orbit.orbit.raan == row['orbit.raan']
        # the sensors keep the scene's seeds (not dispersed)
        assert magnetometer.values['seed'] == 3 and imu.values['seed'] == 5
        final = Plant(loaded, 1.0).run(60.0).omega_B[-1]
        assert final.tolist() == [row['final_wx'], row['final_wy'], row['final_wz']]


def test_a_drawn_sensor_parameter_or_fault_field_the_scene_refuses_fails_its_run():
    """A negative noise or fault start drawn: the run is ``invalid_scene``, the field named."""
    data = sensor_campaign(runs=2)
    data['dispersions'] = {
        'effects[1].magnetometer.noise': {'replace': {'values': [2e-7, -1e-9]}},
        'faults[0].bias.start': {'replace': {'values': [-1.0, 3.0]}},
    }
    rows = run_campaign(data, scheduler='in-process').to_pylist()
    assert rows[0]['status'] == rows[1]['status'] == 'invalid_scene'
    assert rows[0]['reason'].startswith('faults[0].bias.start: must be >= 0')
    assert rows[1]['reason'].startswith('effects[1].magnetometer.noise: must be >= 0')


def test_an_actuator_faults_window_and_value_disperse_per_run_and_change_its_motion(tmp_path):
    """
    A stuck magnetorquer's start and dipole drawn per run: in the run's scene and in its motion.

    The plant applies the scene's actuator faults, so the runs' final rates differ with the draw;
    the run's scene written out and run on the plant ends with the table's rates exactly.
    """
    with open(load_scene('bdot_detumble').source) as file:
        scene = yaml.safe_load(file)
    scene['faults'] = [
        {'magnetorquer_stuck': {'start': 10.0, 'end': 20.0, 'value': [0.1, 0.0, -0.1]}}
    ]
    data = campaign(scene, {
        'faults[0].magnetorquer_stuck.start': {'absolute': {'uniform': {'low': -5.0,
                                                                        'high': 5.0}}},
        'faults[0].magnetorquer_stuck.value': {'relative': {'normal': {'sigma': 0.2}}},
    }, runs=2, duration=30.0)
    rows = run_campaign(data, scheduler='in-process').to_pylist()
    for run, row in enumerate(rows):
        assert row['status'] == 'ok'
        path = tmp_path / f'run{run}.yaml'
        path.write_text(yaml.safe_dump(run_scene(data, run)))
        loaded = load_scene(str(path))
        (fault,) = loaded.faults
        assert fault.start == row['faults[0].magnetorquer_stuck.start'] != 10.0
        assert list(fault.value) == [
            row[f'faults[0].magnetorquer_stuck.value[{k}]'] for k in range(3)
        ]
        final = Plant(loaded, 1.0).run(30.0).omega_B[-1]
        assert final.tolist() == [row['final_wx'], row['final_wy'], row['final_wz']]
    assert rows[0]['final_wx'] != rows[1]['final_wx']


@pytest.mark.parametrize(
    'key, message',
    [
        ('effects[1].magnetometer.seed', 'a seed is not a physical parameter'),
        ('effects[2].imu.seed', 'a seed is not a physical parameter'),
        ('faults[0].noise.sigma', 'outside the scene: faults[0] is bias, not'),
        ('faults[2].bias.start', 'outside the scene: it has 2 faults (faults[0] to faults[1])'),
        ('faults[0].bias.output', 'only a number or a list of numbers can be dispersed'),
        ('faults[0].bias.sigma', "bias has no field 'sigma'"),
        ('faults[1].noise.end', "'replace'"),  # the scene gives no end: only a replacement
        ('faults[0].bias.step[3]', 'outside the scene: bias.step has 3 items'),
    ],
)
def test_bad_sensor_and_fault_targets_are_refused_with_their_path(key, message):
    data = sensor_campaign()
    data['dispersions'] = {key: {'absolute': {'normal': {'sigma': 1.0}}}}
    with pytest.raises(CampaignError) as error:
        load_campaign(data)
    assert f'dispersions.{key}' in str(error.value)
    assert message in str(error.value)
