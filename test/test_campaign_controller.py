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
Closed-loop campaigns: a law run per run on the batched plant (campaigns.controllers).

The promises: a run of a closed-loop campaign is the plant driven by hand with the same law on
that run's scene (``campaigns.run_scene``), bit for bit; the table is the same in-process, with
other chunks and on Dask workers; the built-in B-dot is the example's law, held to an independent
computation; per-run sensor seeds are the documented SeedSequence's; bad controller sections are
refused with the field path.
"""

import math

import numpy as np
import pytest
from test_campaign import assert_same_table
from torquefree_ros import load_scene
from torquefree_ros.campaigns import CampaignError, load_campaign, run_campaign, run_scene
from torquefree_ros.campaigns.controllers import Bdot, sensor_seed
from torquefree_ros.campaigns.engine import plant_steps
from torquefree_ros.plant import Plant
from torquefree_ros.plant.sensors import SensorReadings
import yaml

CONTROL_RATE = 1.0  # Hz
NOISE = 2.0e-7  # T: a magnetometer's 1-sigma noise per axis (200 nT)


def detumble_campaign(runs=5, duration=120.0, **changes) -> dict:
    """
    Return the library's bdot_detumble campaign, shortened, its magnetometer noisy.

    A noisy magnetometer with ``sensor_seeds: per_run`` makes every run's sensor draws its own;
    some runs of a wide ``max_dipole`` dispersion draw a negative one, which the scene refuses.
    """
    data = yaml.safe_load(load_campaign('bdot_detumble').text)
    data.update(runs=runs, duration=duration, sensor_seeds='per_run')
    data['scene']['effects'][1] = {'magnetometer': {'noise': NOISE, 'seed': 5}}
    data['dispersions']['controller.gain'] = {'relative': {'uniform': {'low': -0.3, 'high': 0.3}}}
    data.update(changes)
    return data


def by_hand(campaign, run: int, law_class=Bdot) -> dict:
    """
    Drive the run's scene by hand: ``Plant`` stepped at the controller's rate, the law answering.

    Return its rates at the campaign's samples and its magnetometer's largest |B| over them.
    """
    scene = load_scene_mapping(run_scene(campaign, run))
    plant = Plant([scene], CONTROL_RATE)
    sensors = plant.sensors()
    gain = campaign.controller.parameters['gain']
    drawn = yaml.safe_load(campaign.text)['dispersions']
    if 'controller.gain' in drawn:
        from torquefree_ros.campaigns.engine import draw_run

        gain = float(draw_run(campaign, run).values['controller.gain'][0])
    law = law_class([scene], CONTROL_RATE, {'gain': np.array([gain])})
    every = round(CONTROL_RATE / campaign.rate)
    rates, fields = [], []
    for k in range(plant_steps(campaign)):
        readings = sensors.read()
        commands = law(readings)
        if k % every == 0:
            rates.append(plant.state.omega_B[0])
            fields.append(np.linalg.norm(readings.rows['magnetometer'][0, :3]))
        if k == plant_steps(campaign) - 1:
            break
        plant.step(**commands)
    return {'omega': np.array(rates), 'field_peak': max(fields)}


def load_scene_mapping(mapping):
    from torquefree_ros.core.scene.loader import scene_from_mapping

    return scene_from_mapping(mapping, source='run')


def test_a_run_is_the_plant_driven_by_hand_with_the_law_and_its_own_sensor_seeds():
    campaign = load_campaign(detumble_campaign(runs=4))
    table = run_campaign(campaign, scheduler='in-process')
    assert table.column('status').to_pylist() == ['ok'] * 4
    seeds = []
    for run in range(4):
        scene = run_scene(campaign, run)
        (magnetometer,) = [e['magnetometer'] for e in scene['effects'] if 'magnetometer' in e]
        # the documented seed: the first 63 bits of SeedSequence(seed, spawn_key=(run, j)), j = 0
        # (the magnetometer is the scene's first output)
        state = np.random.SeedSequence(campaign.seed, spawn_key=(run, 0)).generate_state(
            1, np.uint64
        )
        assert magnetometer['seed'] == int(state[0]) >> 1 == sensor_seed(campaign.seed, run, 0)
        seeds.append(magnetometer['seed'])
        hand = by_hand(campaign, run)
        final = [table.column(f'final_w{a}')[run].as_py() for a in 'xyz']
        assert final == hand['omega'][-1].tolist()  # bit for bit
        # the same readings; |B| summed in another order: rounding, 1e-15 relative
        assert table.column('sensor_peak')[run].as_py() == pytest.approx(
            hand['field_peak'], rel=1e-15
        )
        below = np.linalg.norm(hand['omega'], axis=1) < 0.008726646259971648
        settled = table.column('settle_time')[run].as_py()
        if below[-1]:
            first = len(below) - np.argmin(below[::-1])  # after the last sample above
            assert settled == (first if not below.all() else 0) / campaign.rate
        else:
            assert math.isnan(settled)
    assert len(set(seeds)) == 4
    # sensor_seeds: scene keeps the scene's seed in every run
    same = load_campaign(detumble_campaign(runs=2, sensor_seeds='scene'))
    for run in range(2):
        effects = run_scene(same, run)['effects']
        assert [e['magnetometer']['seed'] for e in effects if 'magnetometer' in e] == [5]


def test_the_bdot_law_against_the_example_s_rule_computed_independently():
    """
    Three orthogonal rods: the example's rule on Python floats, to rounding.

    ``m = -k (B_k - B_k-1) / h``, scaled by ``max_dipole / max |m_i|`` when a component passes
    it (examples/bdot_detumble_controller.py, with each rod's own limit: ``min_i max_i / |m_i|``).
    The law computes the scale from the least-norm allocation (pinv of the axes, the identity to
    rounding), so it agrees to a few ulps: 1e-15 relative to |m|.
    """
    rng = np.random.default_rng(3)
    scenes = []
    limits = rng.uniform(0.1, 0.3, size=(6, 3))
    for row in limits:
        data = yaml.safe_load(load_campaign('bdot_detumble').text)['scene']
        for rod, limit in zip(data['effects'][0]['magnetorquers']['rods'], row):
            rod['max_dipole'] = float(limit)
        scenes.append(load_scene_mapping(data))
    gains = rng.uniform(2e4, 2e5, size=6)
    law = Bdot(scenes, 1.0, {'gain': gains})
    fields = rng.normal(0.0, 3e-5, size=(4, 6, 3))
    published = np.ones((4, 6), bool)
    published[2, 1] = False  # body 1 misses sample 2: its command holds, then spans 2 s
    expected_last = [None] * 6
    previous = [[0.0, 0.0, 0.0]] * 6
    for k in range(4):
        rows = np.concatenate([fields[k], np.zeros((6, 9))], axis=1)
        rows[~published[k]] = np.nan
        readings = SensorReadings(
            k, float(k), {'magnetometer': rows}, {'magnetometer': published[k]}
        )
        dipole = law(readings)['dipole']
        for b in range(6):
            if not published[k, b]:
                expected = previous[b]
            elif expected_last[b] is None:
                expected = [0.0, 0.0, 0.0]
            else:
                t0, b0 = expected_last[b]
                m = [-gains[b] * (x1 - x0) / (k - t0) for x1, x0 in zip(fields[k, b], b0)]
                scale = min(1.0, *(lim / abs(x) for lim, x in zip(limits[b], m) if x))
                expected = [x * scale for x in m]
            if published[k, b]:
                expected_last[b] = (k, fields[k, b])
            assert dipole[b] == pytest.approx(expected, rel=1e-15, abs=1e-15 * max(
                1e-300, max(map(abs, expected))))
            # scaled into the rods: none beyond its limit (rounding: 1e-15)
            assert np.all(np.abs(dipole[b]) <= limits[b] * (1 + 1e-15))
        previous = [row.tolist() for row in dipole]
    assert np.any(np.abs(np.abs(dipole) / limits - 1.0) < 1e-15)  # some rod at its limit


def test_the_table_is_the_same_in_process_with_other_chunks_and_on_workers():
    """Failed runs (a negative max_dipole drawn) are rows with the scene's reason, everywhere."""
    wide = {'relative': {'normal': {'sigma': 0.8}}}
    data = detumble_campaign(runs=24, duration=60.0)
    data['dispersions']['effects[0].magnetorquers.rods[1].max_dipole'] = wide
    reference = run_campaign(data, scheduler='in-process')
    status = reference.column('status').to_pylist()
    failed = [i for i, s in enumerate(status) if s != 'ok']
    assert 0 < len(failed) < len(status)
    for i in failed:
        assert status[i] == 'invalid_scene'
        assert 'max_dipole' in reference.column('reason')[i].as_py()
    assert_same_table(reference, run_campaign(data, scheduler='in-process', chunk_size=5))
    assert_same_table(reference, run_campaign(data, scheduler='local', workers=2, chunk_size=7))


def test_a_python_law_is_named_by_module_and_factory_and_commands_like_a_built_in_one():
    """The built-in law named as a user's factory gives the same table as ``law: bdot``."""
    data = detumble_campaign(runs=3, duration=60.0)
    reference = run_campaign(data, scheduler='in-process')
    data['controller'] = {
        'python': 'torquefree_ros.campaigns.controllers:Bdot',
        'rate': 1.0,
        'parameters': {'gain': 100000.0},
    }
    assert_same_table_but_source(reference, run_campaign(data, scheduler='in-process'))


def rate_damping(scenes, rate, parameters):
    """Make a user's law: ``tau = -K w_gyro`` from the imu (its rates: the row's [13:16])."""
    gain = parameters['gain'][:, None]

    def law(readings):
        return {'torque': np.clip(-gain * readings.rows['imu'][:, 13:16], -0.05, 0.05)}

    return law


def test_a_user_s_torque_law_on_the_gyro_damps_the_rates_to_its_closed_form():
    """
    ``tau = -K w`` on a sphere (I = 1 kg m^2): ``w(t) = w0 (1 - K h)^(t / h)``, held at 10 Hz.

    The gyro is exact (no noise) and the torque stays below its limit, so the discrete closed
    form holds to the integrator's tolerance (1e-9 relative, the scene's accuracy; measured
    ~1e-12).
    """
    data = {
        'scene': {
            'body': {'inertia': [1.0, 1.0, 1.0]},
            'initial': {'angular_velocity': [0.01, -0.02, 0.015]},
            'effects': [{'torque_command': {'max_torque': 1.0}}, {'imu': {}}],
            'accuracy': 1.0e-10,
        },
        'runs': 2,
        'seed': 1,
        'duration': 5.0,
        'rate': 1.0,
        'controller': {
            'python': 'test_campaign_controller:rate_damping',
            'rate': 10.0,
            'parameters': {'gain': 0.5},
        },
        'metrics': ['final_rates'],
    }
    table = run_campaign(data, scheduler='in-process')
    w = [table.column(f'final_w{a}')[0].as_py() for a in 'xyz']
    assert w == pytest.approx(
        np.array([0.01, -0.02, 0.015]) * (1 - 0.5 * 0.1) ** 50, rel=1e-9
    )


def assert_same_table_but_source(a, b):
    """Assert the same columns bit for bit; the campaign file (metadata) differs."""
    assert a.column_names == b.column_names
    for name in a.column_names:
        x, y = a.column(name).to_numpy(), b.column(name).to_numpy()
        if x.dtype == np.float64:
            x, y = x.view(np.int64), y.view(np.int64)  # NaN included
        assert np.array_equal(x, y), name


@pytest.mark.parametrize(
    'change, expected',
    [
        ({'controller': {'law': 'pid', 'rate': 1}}, "controller.law: unknown law 'pid'"),
        ({'controller': {'rate': 1}}, 'controller: name the law once'),
        (
            {'controller': {'law': 'bdot', 'python': 'a.b:c', 'rate': 1}},
            'controller: name the law once',
        ),
        ({'controller': {'law': 'bdot', 'rate': 0}}, 'controller.rate: must be > 0'),
        ({'controller': {'law': 'bdot', 'rate': -1}}, 'controller.rate: must be > 0'),
        (
            {'controller': {'law': 'bdot', 'rate': 0.25}},
            "controller.rate: 0.25 Hz is not a whole multiple of the campaign's rate 0.1 Hz",
        ),
        ({'controller': {'law': 'bdot'}}, 'controller.rate'),
        (
            {'controller': {'law': 'bdot', 'rate': 1, 'parameters': {'gian': 1.0}}},
            'controller.parameters.gian',
        ),
        (
            {'controller': {'law': 'bdot', 'rate': 1, 'parameters': {'gain': -1.0}}},
            'controller.parameters.gain: must be > 0',
        ),
        (
            {'controller': {'python': 'no_such_module_here:law', 'rate': 1}},
            'controller.python: cannot import no_such_module_here',
        ),
        (
            {'controller': {'python': 'torquefree_ros.campaigns.controllers', 'rate': 1}},
            "controller.python: expected 'package.module:factory'",
        ),
        (
            {'controller': {'python': 'torquefree_ros.campaigns.controllers:nope', 'rate': 1}},
            "controller.python: torquefree_ros.campaigns.controllers has no callable 'nope'",
        ),
        ({'sensor_seeds': 'each'}, 'sensor_seeds'),
        (
            {'dispersions': {'controller.k': {'relative': {'normal': {'sigma': 0.1}}}}},
            "dispersions.controller.k: the controller has no parameter 'k'",
        ),
        (
            {'metrics': [{'sensor_peak': {'topic': 'sun_sensor'}}]},
            "metrics[0].sensor_peak: topic: the scene has no output on 'sun_sensor'",
        ),
    ],
)
def test_a_bad_controller_section_names_the_field(change, expected, tmp_path):
    data = yaml.safe_load(load_campaign('bdot_detumble').text)
    data.update(change)
    if 'dispersions' in change:
        data['dispersions'] = change['dispersions']
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    assert str(error.value).startswith(f'{path}: ')
    assert expected in str(error.value)


def test_a_law_the_scene_cannot_serve_and_a_metric_without_a_controller_are_refused():
    data = yaml.safe_load(load_campaign('bdot_detumble').text)
    del data['scene']['effects'][1]  # no magnetometer
    with pytest.raises(CampaignError, match=r'controller.law: bdot reads a magnetometer output'):
        load_campaign(data)
    data = yaml.safe_load(load_campaign('bdot_detumble').text)
    data['scene']['effects'] = [data['scene']['effects'][1]]  # no rods
    data['dispersions'] = {}
    with pytest.raises(CampaignError, match=r'controller.law: bdot commands magnetorquers'):
        load_campaign(data)
    data = yaml.safe_load(load_campaign('bdot_detumble').text)
    del data['controller']
    with pytest.raises(CampaignError, match=r"metrics\[1\]: dipole_duty measures a controller's"):
        load_campaign(data)
    # a magnetometer at 0.3 Hz is not read at the controller's 1 Hz samples
    data = yaml.safe_load(load_campaign('bdot_detumble').text)
    data['scene']['effects'][1] = {'magnetometer': {'rate': 0.3}}
    with pytest.raises(CampaignError, match=r'controller.rate: output magnetometer'):
        load_campaign(data)


def test_an_open_loop_campaign_measures_its_sensors_stepping_the_plant():
    """No controller: the plant steps at the campaign's rate, its sensors read every sample."""
    data = detumble_campaign(runs=2, duration=30.0, rate=1.0)
    del data['controller']
    del data['dispersions']['controller.gain']
    data['metrics'] = [{'sensor_peak': {'topic': 'magnetometer'}}, 'final_rates']
    campaign = load_campaign(data)
    table = run_campaign(campaign, scheduler='in-process')
    for run in range(2):
        plant = Plant([load_scene_mapping(run_scene(campaign, run))], 1.0)
        sensors = plant.sensors()
        peak = 0.0
        for k in range(31):
            peak = max(peak, float(np.linalg.norm(sensors.read().rows['magnetometer'][0, :3])))
            if k < 30:
                plant.step()
        # the same readings; |B| summed in another order: rounding, 1e-15 relative
        assert table.column('sensor_peak')[run].as_py() == pytest.approx(peak, rel=1e-15)
        # the Earth's field at 500 km: 20 to 50 microtesla (an order-of-magnitude check)
        assert 2e-5 < peak < 5e-5


def test_the_library_scene_and_the_campaign_s_inline_scene_are_the_same_body_and_orbit():
    campaign = load_campaign('bdot_detumble')
    library = load_scene('bdot_detumble')
    assert list(campaign.scene.inertia) == list(library.inertia)
    assert list(campaign.scene.angular_velocity) == list(library.angular_velocity)
    assert campaign.runs == 1000 and campaign.controller.rate == 1.0
    assert campaign.duration == pytest.approx(3 * 2 * math.pi / math.sqrt(
        3.986004418e14 / 6878137.0**3), rel=1e-3)  # three orbits, to the second


def picky_damping(scenes, rate, parameters):
    """Make a law that refuses gains above 0.6 (a user's bug, pinned on the runs it hits)."""
    if np.any(parameters['gain'] > 0.6):
        raise KeyError('gain above 0.6')
    return rate_damping(scenes, rate, parameters)


def wrong_answer(scenes, rate, parameters):
    """Make a law that answers a command the plant does not take."""
    return lambda readings: {'force': np.zeros((len(scenes), 3))}


def test_a_law_that_fails_fails_its_runs_only_with_its_reason():
    data = {
        'scene': {
            'body': {'inertia': [1.0, 1.0, 1.0]},
            'initial': {'angular_velocity': [0.01, -0.02, 0.015]},
            'effects': [{'torque_command': {'max_torque': 1.0}}, {'imu': {}}],
        },
        'runs': 8,
        'seed': 3,
        'duration': 2.0,
        'rate': 1.0,
        'controller': {
            'python': 'test_campaign_controller:picky_damping',
            'rate': 10.0,
            'parameters': {'gain': 0.5},
        },
        'dispersions': {'controller.gain': {'absolute': {'uniform': {'low': 0.0, 'high': 0.2}}}},
        'metrics': ['final_rates'],
    }
    table = run_campaign(data, scheduler='in-process')
    gains = np.array(table.column('controller.gain').to_pylist())
    status = table.column('status').to_pylist()
    assert 0 < np.count_nonzero(gains > 0.6) < 8  # both kinds of runs
    assert status == ['failed' if g > 0.6 else 'ok' for g in gains]
    for i in np.flatnonzero(gains > 0.6):
        assert table.column('reason')[int(i)].as_py() == (
            "controller test_campaign_controller:picky_damping: KeyError: 'gain above 0.6'"
        )
    data['controller']['python'] = 'test_campaign_controller:wrong_answer'
    table = run_campaign(data, scheduler='in-process')
    assert set(table.column('status').to_pylist()) == {'failed'}
    assert table.column('reason')[0].as_py() == (
        'controller test_campaign_controller:wrong_answer: a law answers a dict of dipole, '
        "torque, wheels, got dict with ['force']"
    )
