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
The free gyrostat in the work-precision bench (``torquefree_bench --smoke --case gyrostat/...``).

Its cases come from the gyrostat's mpmath reference; every method that applies runs them (the
exact gyrostat, our integrators, scipy's), the free body's exact solution and MuJoCo's free body
do not; the exact gyrostat meets the reference at the issue's 1e-13.
"""

import dataclasses
import math

import numpy as np
import pytest
from torquefree_ros.bench.cases import (
    BENCH_CASES,
    FREE_BODY_CASES,
    GYROSTAT_CASES,
    GYROSTAT_SMOKE_CASES,
    load_cases,
)
from torquefree_ros.bench.methods import all_methods, exact_gyrostat
from torquefree_ros.bench.report import read_csv
from torquefree_ros.cli import bench as cli
from torquefree_ros.core.scene.loader import scene_from_mapping

#: the issue's target for the exact gyrostat against the mpmath reference (rad; relative rate)
TARGET = 1e-13


@pytest.fixture(scope='module')
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp('bench_gyrostat')
    argv = ['--smoke', '--no-costs', '--output-dir', str(out)]
    for name in GYROSTAT_SMOKE_CASES:
        argv += ['--case', name]
    assert cli.main(argv) == 0
    return out


def test_every_applicable_method_runs_each_gyrostat_case(smoke):
    rows = read_csv(smoke / 'work_precision.csv')
    assert {row['case'] for row in rows} == set(GYROSTAT_SMOKE_CASES)
    for case in load_cases(GYROSTAT_SMOKE_CASES):
        ran = {row['method'] for row in rows if row['case'] == case.name}
        assert ran == {m.label for m in all_methods() if m.applies(case)}
        assert 'gyrostat' in ran and {'dop853', 'rk4', 'scipy DOP853'} <= ran
        assert not ran & {'analytic', 'mujoco RK4'}  # the free body's alone
    for row in rows:
        assert row['status'] == 'ok', row
        assert float(row['cpu_us_per_sim_s']) > 0 and float(row['cpu_ms_to_horizon']) > 0


def test_the_exact_gyrostat_meets_the_reference(smoke):
    exact = [row for row in read_csv(smoke / 'work_precision.csv') if row['method'] == 'gyrostat']
    assert len(exact) == len(GYROSTAT_SMOKE_CASES)
    for row in exact:
        # measured: 2e-14 rad and 4e-15 rad, relative rates 1e-15 and 1e-14
        assert float(row['attitude_error_rad']) <= TARGET, row
        assert float(row['rate_error_rel']) <= TARGET, row


def test_the_integrators_errors_fall_with_the_tighter_setting(smoke):
    """As on the free body: a factor 1e4 in tolerance or 8 in step (>= 8^4 for 4th order)."""
    pairs = {}
    for row in read_csv(smoke / 'work_precision.csv'):
        if row['setting']:
            pairs.setdefault((row['case'], row['method']), []).append(row)
    assert pairs
    for key, (loose, tight) in pairs.items():
        assert float(tight['setting']) < float(loose['setting']), key
        assert float(tight['attitude_error_rad']) < 0.1 * float(loose['attitude_error_rad']), key
        # none reaches the exact gyrostat's level at the smoke run's settings
        assert float(tight['attitude_error_rad']) > TARGET, key


def test_the_report_shows_the_gyrostat_beside_the_integrators(smoke):
    text = (smoke / 'results.md').read_text()
    assert '### gyrostat/library_gyrostat' in text
    assert 'The free gyrostat: a rotor of 5 N m s along [0.0, 1.0, 0.0].' in text
    assert 'The free gyrostat: coasting reaction wheels' in text
    # the exact propagator of the gyrostat cases is the gyrostat: it heads the DOP853 ratios
    assert '- gyrostat/library_gyrostat (exact: ' in text
    assert '| gyrostat | ' in text
    png = (smoke / 'work_precision.png').read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n'


def test_the_full_report_holds_both_sets_the_free_body_first():
    assert BENCH_CASES == FREE_BODY_CASES + GYROSTAT_CASES
    assert all(name.startswith('gyrostat/') for name in GYROSTAT_CASES)
    # both references hold a long_horizon_1e5: the prefix keeps them apart
    free, gyrostat = load_cases(['long_horizon_1e5', 'gyrostat/long_horizon_1e5'])
    assert free.effects == () and gyrostat.effects[0]['rotor']['momentum'] == 0.01
    # the free body's step unit is unchanged: 2 pi / |w0|
    assert free.rotation_period == 2.0 * math.pi / float(np.linalg.norm(free.angular_velocity))


def test_a_dominant_rotor_sets_the_fixed_steps_unit():
    """``2 pi / (|w0| + |h| / min I)``: the rotor's 100 N m s on I = 1 is ~100 rad/s."""
    (case,) = load_cases(['gyrostat/dominant_h'])
    rate = float(np.linalg.norm(case.angular_velocity)) + 100.0 / 1.0
    assert case.rotation_period == pytest.approx(2.0 * math.pi / rate, rel=1e-15)


def _builds(case) -> bool:
    try:
        scene_from_mapping(case.scene_mapping()).propagator('gyrostat')
    except ValueError:
        return False
    return True


@pytest.mark.parametrize('name', GYROSTAT_CASES)
def test_the_gyrostat_runs_exactly_the_cases_it_builds_for(name):
    """
    ``applies`` and the propagator agree: every gyrostat case, the oblique rotor included.

    The same case with a damper beside its rotor or wheels is no free gyrostat: left out by both.
    """
    (case,) = load_cases([name])
    assert exact_gyrostat(case) and _builds(case)
    damped = dataclasses.replace(
        case, effects=case.effects + ({'damper': {'inertia': 0.1, 'damping': 0.05}},)
    )
    assert not exact_gyrostat(damped) and not _builds(damped)


def test_an_unknown_case_is_refused_with_both_sets_known():
    with pytest.raises(ValueError, match=r"^case: unknown case 'gyrostat/nope'") as raised:
        load_cases(['gyrostat/nope'])
    assert 'flat_plate' in str(raised.value) and 'gyrostat/dominant_h' in str(raised.value)
