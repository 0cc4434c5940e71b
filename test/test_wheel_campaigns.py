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
Campaigns over reaction wheels (issue 40).

The momentum and energy metrics count the wheels (the whole system's H is conserved under the
motors' internal torques, the body's own ``I w`` is not); ``momentum_peak`` and
``saturation_time`` against the wheel speeds the plant reports; wheel parameters dispersed by path;
axis misalignment with the Rayleigh statistics it promises; the library's wheel campaign the same
in-process and on a local Dask cluster.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from torquefree_ros import Plant
from torquefree_ros.campaigns import CampaignError, library_campaigns, load_campaign, run_campaign
from torquefree_ros.campaigns.dispersions import run_generator
from torquefree_ros.campaigns.engine import _scene_of, draw_run
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.scene.loader import scene_from_mapping
import yaml

ROOT2 = 1.4142135623730951
# a pyramid's axes as the scenes write them (each normalised by the effect)
AXES = ([ROOT2, 0.0, 1.0], [0.0, ROOT2, 1.0], [-ROOT2, 0.0, 1.0], [0.0, -ROOT2, 1.0])
INERTIA = [12.0, 10.0, 8.0]
SPIN_INERTIA = 0.01
MAX_SPEED = 100.0


def wheel(name, axis, speed=0.0):
    return {
        'name': name,
        'axis': list(axis),
        'spin_inertia': SPIN_INERTIA,
        'max_torque': 0.02,
        'max_speed': MAX_SPEED,
        'viscous': 1.0e-5,
        'coulomb': 5.0e-4,
        'speed': speed,
    }


def scene_mapping(schedule, speeds=(30.0, -20.0, 10.0, 0.0), omega=(0.02, -0.01, 0.05)):
    """Return the wheel_slew body and pyramid, its wheels scheduled, limited to 100 rad/s."""
    return {
        'body': {'inertia': list(INERTIA)},
        'initial': {
            'angular_velocity': list(omega),
            'orientation': [0.1, -0.2, 0.3, math.sqrt(1.0 - 0.14)],
        },
        'effects': [
            {
                'reaction_wheels': {
                    'schedule': schedule,
                    'wheels': [
                        wheel(f'rw{i + 1}', axis, speed)
                        for i, (axis, speed) in enumerate(zip(AXES, speeds))
                    ],
                }
            }
        ],
        'accuracy': 1.0e-10,
    }


# internal torques only: motors changing at 7.5 s, and friction
CHANGING = [
    {'start': 0.0, 'torque': [0.02, -0.01, 0.015, -0.02]},
    {'start': 7.5, 'torque': [-0.02, 0.02, 0.0, 0.01]},
]
# every wheel at its torque limit: the array reaches its speed limit after about 50 s
SPIN_UP = [{'start': 0.0, 'torque': [0.02, 0.02, 0.02, 0.02]}]


def plant_run(mapping, duration, rate):
    """Return the plant's samples of a scene: rates, attitudes and wheel speeds, k = 0 .. K."""
    plant = Plant(scene_from_mapping(copy.deepcopy(mapping)), rate)
    first = plant.state
    rest = plant.run(duration)
    return tuple(
        np.concatenate([a0[None], a])
        for a0, a in (
            (first.omega_B, rest.omega_B),
            (first.q_NB, rest.q_NB),
            (first.wheel_speeds, rest.wheel_speeds),
        )
    )


def unit_axes():
    axes = np.array(AXES)
    return axes / np.linalg.norm(axes, axis=1)[:, None]


def inertial(q, vectors):
    return np.array([quaternion.rotate(qk, v) for qk, v in zip(q, vectors)])


def relative_drift(H_N):
    return float(np.linalg.norm(H_N - H_N[0], axis=1).max() / np.linalg.norm(H_N[0]))


# -- the momentum and energy metrics count the wheels ---------------------------------------------
def test_momentum_drift_counts_the_wheels_momentum_under_internal_torques():
    """
    Under motor torques and friction alone, the whole system's inertial H is constant.

    The campaign's momentum_drift stays at the integrator's error (DOP853 at rtol 1e-10 over 20 s:
    1.7e-10 measured; allowed 1e-8, a hundred times the accuracy asked), and is the drift of
    ``R(q) (I w + sum Js Omega g)`` computed here from the plant's wheel speeds (a second
    formula: the scene's locked inertia and the relative speeds, where the metric takes the
    effect's absolute momenta). The body's own ``R(q) I w`` is far from constant: the wheels
    trade tenths of its momentum.
    """
    mapping = scene_mapping(CHANGING)
    data = {
        'scene': mapping,
        'runs': 1,
        'seed': 0,
        'duration': 20.0,
        'rate': 10.0,
        'metrics': ['momentum_drift', 'energy_drift'],
    }
    row = run_campaign(data, scheduler='in-process').to_pylist()[0]
    assert row['status'] == 'ok'
    assert row['momentum_drift'] < 1e-8
    omega, q, speeds = plant_run(mapping, 20.0, 10.0)
    whole = inertial(q, omega @ np.diag(INERTIA) + SPIN_INERTIA * speeds @ unit_axes())
    # the same drift, by the other formula: rounding of sums of ~1 N m s terms, 1e-12
    assert abs(row['momentum_drift'] - relative_drift(whole)) < 1e-12
    assert relative_drift(inertial(q, omega @ np.diag(INERTIA))) > 0.1
    # the energy the motors put in: T by the other formula, w . I w / 2 + sum Js Omega (g . w +
    # Omega / 2), the relative-speed form of the same energy (rounding, 1e-12 of T)
    g_w = omega @ unit_axes().T
    T = 0.5 * np.einsum('ki,ij,kj->k', omega, np.diag(INERTIA), omega) + SPIN_INERTIA * np.sum(
        speeds * (g_w + 0.5 * speeds), axis=1
    )
    assert abs(row['energy_drift'] - np.abs(T - T[0]).max() / T[0]) < 1e-12


# -- momentum_peak and saturation_time ------------------------------------------------------------
def test_momentum_peak_and_saturation_time_against_the_plants_wheel_speeds():
    """
    The two wheel metrics are what the plant's wheel speeds give, by their definitions.

    momentum_peak: ``max_k |sum Js Omega_i g_i|`` (rounding, 1e-12 relative); saturation_time:
    the sample intervals ending with some ``|Omega_i| >= max_speed - speed_band`` (the default
    band, 1 % of max_speed), 0.1 s each, exact but for the sum's rounding (1e-9 s). The spin-up
    reaches the band: at full torque on a locked body a wheel gains 2 rad/s^2, so about 10 s of
    the minute is spent there (checked between 5 and 15 s so the test cannot pass on zero).
    """
    mapping = scene_mapping(SPIN_UP, speeds=(0.0, 0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.01))
    data = {
        'scene': mapping,
        'runs': 1,
        'seed': 0,
        'duration': 60.0,
        'rate': 10.0,
        'metrics': ['momentum_peak', 'saturation_time'],
    }
    row = run_campaign(data, scheduler='in-process').to_pylist()[0]
    omega, q, speeds = plant_run(mapping, 60.0, 10.0)
    stored = SPIN_INERTIA * speeds @ unit_axes()
    peak = float(np.linalg.norm(stored, axis=1).max())
    assert row['momentum_peak'] == pytest.approx(peak, rel=1e-12)
    in_band = np.any(np.abs(speeds) >= MAX_SPEED - 0.01 * MAX_SPEED, axis=1)
    expected = 0.1 * np.count_nonzero(in_band[1:])
    assert abs(row['saturation_time'] - expected) < 1e-9
    assert 5.0 < row['saturation_time'] < 15.0
    # the array cannot store more than every wheel at its top speed along the pyramid's axis
    assert peak <= 4 * SPIN_INERTIA * MAX_SPEED / math.sqrt(3.0) * (1.0 + 1e-9)


def test_wheel_metrics_are_nan_without_wheels():
    """A run with no reaction wheels has no stored momentum or speed limit: NaN, not 0."""
    data = {
        'scene': 'dzhanibekov',
        'runs': 1,
        'seed': 0,
        'duration': 1.0,
        'rate': 10.0,
        'metrics': ['momentum_peak', 'saturation_time'],
    }
    row = run_campaign(data, scheduler='in-process').to_pylist()[0]
    assert math.isnan(row['momentum_peak']) and math.isnan(row['saturation_time'])


# -- dispersing wheels ----------------------------------------------------------------------------
def test_wheel_parameters_disperse_by_path_into_each_runs_scene():
    """Spin inertia, torque limit, friction and a preset's field reach each run's wheel."""
    mapping = scene_mapping(CHANGING)
    mapping['effects'][0]['reaction_wheels']['wheels'][3] = {
        'name': 'rw4',
        'axis': list(AXES[3]),
        'preset': 'bct_rwp015',
    }
    base = 'effects[0].reaction_wheels.wheels'
    data = {
        'scene': mapping,
        'runs': 3,
        'seed': 7,
        'duration': 1.0,
        'rate': 10.0,
        'dispersions': {
            f'{base}[1].spin_inertia': {'relative': {'normal': {'sigma': 0.1}}},
            f'{base}[1].max_torque': {'absolute': {'uniform': {'low': -0.005, 'high': 0.0}}},
            f'{base}[2].coulomb': {'replace': {'values': [1e-4, 2e-4, 3e-4]}},
            f'{base}[3].spin_inertia': {'relative': {'normal': {'sigma': 0.1}}},
        },
        'metrics': ['momentum_peak'],
    }
    campaign = load_campaign(data)
    preset_js = 0.015 / (6000.0 * 2.0 * math.pi / 60.0)  # the preset's, the dispersion's nominal
    table = run_campaign(data, scheduler='in-process').to_pylist()
    for run, row in enumerate(table):
        assert row['status'] == 'ok'
        rows = _scene_of(campaign, draw_run(campaign, run)).effects[0].rows
        # kernel rows: Js [3], max_torque [4], coulomb [8]
        assert rows[1][3] == row[f'{base}[1].spin_inertia'] != SPIN_INERTIA
        assert rows[1][4] == row[f'{base}[1].max_torque']
        assert rows[2][8] == row[f'{base}[2].coulomb'] == (1e-4, 2e-4, 3e-4)[run]
        assert rows[3][3] == row[f'{base}[3].spin_inertia'] != preset_js
        assert abs(rows[3][3] / preset_js - 1.0) < 0.6  # ~N(1, 0.1): within 6 sigma of it
        assert rows[3][4] == 0.004  # the preset's torque limit, untouched
        assert rows[0][3] == SPIN_INERTIA  # an undispersed wheel keeps its own


def misaligned_campaign(sigma_arcsec, runs):
    mapping = scene_mapping(CHANGING)
    return {
        'scene': mapping,
        'runs': runs,
        'seed': 2026,
        'duration': 1.0,
        'rate': 10.0,
        'dispersions': {
            'effects[0].reaction_wheels.wheels[0].axis': {
                'misalignment': {'sigma': sigma_arcsec}
            },
        },
        'metrics': ['momentum_peak'],
    }


def test_misalignment_tilts_an_axis_by_a_rayleigh_angle_and_keeps_its_length():
    """
    The drawn axes' angles from the nominal have the Rayleigh statistics of ``sigma``.

    4 000 draws of sigma = 600 arcsec: the mean angle is ``sigma sqrt(pi / 2)`` within 5 standard
    errors (the Rayleigh deviation ``sigma sqrt((4 - pi) / 2)`` over sqrt(4 000): 1.0 % of sigma);
    half the angles lie under the median ``sigma sqrt(2 ln 2)`` within 5 binomial standard errors
    (0.79 %); the azimuth about the axis is uniform (its mean resultant length, whose expectation
    is sqrt(pi / (4 N)) ~ 0.014, under 0.05). Each drawn axis keeps the nominal's length to 4
    rounding units; the effect normalises it, and the unit axis it integrates with is a unit
    vector to 4 rounding units.
    """
    draws = 4000
    sigma = 600.0 * math.pi / (180.0 * 3600.0)
    campaign = load_campaign(misaligned_campaign(600.0, draws))
    (target,) = campaign.targets
    nominal = np.array(AXES[0])
    drawn = np.array([target.draw(run_generator(campaign.seed, i), i) for i in range(draws)])
    length = np.linalg.norm(nominal)
    assert np.all(np.abs(np.linalg.norm(drawn, axis=1) - length) <= 4 * 2.2e-16 * length)
    unit = nominal / length
    angles = np.arctan2(np.linalg.norm(np.cross(unit, drawn), axis=1), drawn @ unit)
    standard_error = sigma * math.sqrt((4.0 - math.pi) / 2.0) / math.sqrt(draws)
    assert abs(angles.mean() - sigma * math.sqrt(math.pi / 2.0)) < 5 * standard_error
    below_median = np.mean(angles < sigma * math.sqrt(2.0 * math.log(2.0)))
    assert abs(below_median - 0.5) < 5 * math.sqrt(0.25 / draws)
    # azimuth of each tilt in the plane normal to the axis
    tilt = drawn / length - np.outer(drawn @ unit / length, unit)
    azimuth = np.arctan2(tilt @ np.cross(unit, [0.0, 1.0, 0.0]), tilt @ [0.0, 1.0, 0.0])
    assert abs(np.mean(np.exp(1j * azimuth))) < 0.05
    # a run's effect: the axis it integrates with is unit
    effect = _scene_of(campaign, draw_run(campaign, 3)).effects[0]
    assert abs(np.linalg.norm(effect.axes[0]) - 1.0) <= 4 * 2.2e-16


@pytest.mark.parametrize(
    'dispersion, message',
    [
        (
            {'misalignment': {'sigma': -1.0}},
            'dispersions.effects[0].reaction_wheels.wheels[0].axis.misalignment.sigma: must be '
            '>= 0',
        ),
        (
            {'misalignment': {'sigma': 1.0}, 'direction': {'cone': {'half_angle': 0.1}}},
            'dispersions.effects[0].reaction_wheels.wheels[0].axis.misalignment: turns the '
            'direction as direction does',
        ),
        (
            {'misalignment': {'sigm': 1.0}},
            'dispersions.effects[0].reaction_wheels.wheels[0].axis.misalignment',
        ),
    ],
)
def test_bad_misalignment_is_refused_with_its_field_path(dispersion, message):
    data = misaligned_campaign(1.0, 1)
    data['dispersions'] = {'effects[0].reaction_wheels.wheels[0].axis': dispersion}
    with pytest.raises(CampaignError) as error:
        load_campaign(data)
    assert message in str(error.value)


def test_an_inline_scene_error_names_its_field_under_scene():
    data = misaligned_campaign(1.0, 1)
    data['scene']['effects'][0]['reaction_wheels']['wheels'][0]['spin_inertia'] = -1.0
    with pytest.raises(CampaignError) as error:
        load_campaign(data)
    assert (
        '<mapping>: scene.effects[0].reaction_wheels.wheels[0].spin_inertia: must be > 0'
        in str(error.value)
    )


# -- the library's wheel campaign -----------------------------------------------------------------
@pytest.fixture(scope='module')
def cluster():
    """Two worker processes on loopback, started once for the module."""
    from torquefree_ros.campaigns.engine import local_cluster

    with np.errstate(all='ignore'):  # the module-scoped fixture runs outside the per-test errstate
        local = local_cluster(2)
    try:
        yield local
    finally:
        local.close()


def test_library_wheel_campaign_is_the_same_in_process_and_on_a_local_cluster(cluster):
    """
    wheel_spin_up, cut to 12 runs: every run saturates and the two engines agree bit for bit.

    At full torque a wheel (Js ~ 0.01, limit ~ 0.02 N m) reaches the band of its 100 rad/s limit
    in about 50 s of the minute; momentum_peak stays under the array's capacity along z,
    ``4 Js_max 100 / sqrt(3)`` with Js within 6 sigma (30 %) of nominal.
    """
    path = library_campaigns()['wheel_spin_up']
    data = yaml.safe_load(path.read_text())
    data['runs'] = 12
    reference = run_campaign(data, scheduler='in-process')
    rows = reference.to_pylist()
    assert {row['status'] for row in rows} == {'ok'}
    for row in rows:
        assert 0.0 < row['saturation_time'] < 30.0
        assert 0.0 < row['momentum_peak'] < 4 * 1.3 * SPIN_INERTIA * MAX_SPEED / math.sqrt(3.0)
        assert row['momentum_drift'] < 1e-6  # the whole system's H: integrator error (rtol 1e-9)
    on_workers = run_campaign(data, scheduler=cluster.scheduler_address, chunk_size=5)
    assert on_workers.equals(reference)
