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
The work-precision bench (``torquefree_bench --smoke``).

Its outputs have the promised columns and sections, every method's error falls with its tighter
setting, and the methods agree with the independent reference where they should. The full run is a
command (``make bench``), not a test.
"""

import math

import pytest
from torquefree_ros.bench import sweep
from torquefree_ros.bench.cases import load_cases, SMOKE_CASES
from torquefree_ros.bench.methods import all_methods, mujoco_available
from torquefree_ros.bench.report import read_csv
from torquefree_ros.bench.sweep import Measurement
from torquefree_ros.cli import bench as cli
from torquefree_ros.core.run.accuracy import trajectory_errors


@pytest.fixture(scope='module')
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp('bench')
    assert cli.main(['--smoke', '--output-dir', str(out)]) == 0
    return out


def test_csv_has_every_column_and_names_the_machine_and_versions(smoke):
    text = (smoke / 'work_precision.csv').read_text()
    header = dict(line[2:].split(': ', 1) for line in text.splitlines() if line.startswith('# '))
    assert {'machine', 'python', 'numpy', 'scipy'} <= set(header)
    rows = read_csv(smoke / 'work_precision.csv')
    assert list(rows[0]) == Measurement.columns()
    methods = {m.label for m in all_methods()}
    assert {
        'analytic',
        'rk4',
        'lie_rk4',
        'dop853',
        'scipy RK45',
        'scipy DOP853',
        'scipy Radau',
        'scipy LSODA',
    } <= methods
    assert {(row['case'], row['method']) for row in rows} == {
        (c.name, m.label) for c in load_cases(SMOKE_CASES) for m in all_methods() if m.applies(c)
    }
    for row in rows:
        assert row['status'] == 'ok', row
        assert float(row['cpu_us_per_sim_s']) > 0 and float(row['cpu_ms_to_horizon']) > 0
        # the stream is the 100 Hz grid over the window, both ends included
        assert int(row['samples']) == round(100 * float(row['window_s'])) + 1
        per_second = int(row['samples']) / float(row['window_s'])
        assert float(row['cpu_us_per_sample']) * per_second == pytest.approx(
            float(row['cpu_us_per_sim_s']), rel=1e-3
        )


def test_errors_fall_with_the_tighter_setting(smoke):
    rows = read_csv(smoke / 'work_precision.csv')
    pairs = {}
    for row in rows:
        if row['setting']:
            pairs.setdefault((row['case'], row['method']), []).append(row)
    assert pairs
    for (case, method), (loose, tight) in pairs.items():
        # the smoke settings are a factor 1e4 in tolerance or 8 in step apart (>= 8^4 for 4th
        # order)
        tighter = float(tight['setting']) < float(loose['setting'])
        assert tighter, (case, method)
        assert float(tight['attitude_error_rad']) < 0.1 * float(loose['attitude_error_rad']), (
            case,
            method,
        )
        assert float(tight['rate_error_rel']) < float(loose['rate_error_rel']), (case, method)


def test_the_exact_propagator_is_at_the_float64_floor(smoke):
    for row in read_csv(smoke / 'work_precision.csv'):
        if row['method'] == 'analytic':
            assert float(row['attitude_error_rad']) <= 100 * max(
                float(row['attitude_floor_rad']), 1e-15
            )


def test_report_has_the_tables_targets_plot_and_costs(smoke):
    text = (smoke / 'results.md').read_text()
    for heading in (
        '## Targets',
        '## Per case',
        '### flat_plate',
        '## What each effect adds',
        '## The whole cost of a sample',
        'make bench-bag',
    ):
        assert heading in text
    assert '| method | to reach 1e-06 rad | to reach 1e-09 rad | to reach 1e-12 rad |' in text
    for effect in ('gravity_gradient', 'damper', 'rotor', 'imu', 'euler_angles', 'node publishes'):
        assert effect in text
    png = (smoke / 'work_precision.png').read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 20_000


@pytest.mark.skipif(not mujoco_available(), reason='mujoco (the bench extra) is not installed')
def test_mujoco_free_body_follows_the_reference():
    """
    The conventions of MuJoCo's free joint (body-frame rate, w-first quaternion) are read right.

    At a small step the rates agree with the mpmath reference.
    """
    case = load_cases(['flat_plate'])[0]
    mujoco = next(m for m in all_methods() if m.label == 'mujoco RK4')
    omega, q = mujoco.run(case, 1e-3, case.times)
    rate, attitude = trajectory_errors(omega, q, case.omega, case.q)
    assert rate.max() < 1e-9
    # its RK4 moves the attitude less accurately than the rates (1e-6 rad at this step, measured)
    assert attitude.max() < 1e-5


@pytest.mark.parametrize(
    'argv, message',
    [
        (['--case', 'flat_plat'], "case: unknown case 'flat_plat'"),
        (['--method', 'rk5'], "--method: unknown method 'rk5'"),
        (['--output-dir', '/proc/forbidden'], '--output-dir: cannot create /proc/forbidden'),
    ],
)
def test_bad_arguments_are_refused_with_the_field(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(['--smoke', '--no-costs', *argv])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err


def test_a_sweep_skips_settings_over_its_step_budget(monkeypatch):
    """Fixed-step settings that would take too many steps are recorded as skipped, not run."""
    monkeypatch.setitem(sweep.STEP_LIMIT, 'torquefree_ros', 1000)
    case = load_cases(['flat_plate'])[0]  # 30 s; one rotation ~6 s
    rk4 = next(m for m in all_methods(include_mujoco=False) if m.label == 'rk4')
    results = sweep.sweep([rk4], [case], smoke=True)
    coarse, fine = results  # 32 and 256 steps per rotation: ~160 and ~1280 steps over 30 s
    assert coarse.ok and math.isfinite(coarse.attitude_error_rad)
    assert fine.status.startswith('skipped: 1.3e+03 steps over the limit 1e+03')
    assert math.isnan(fine.cpu_us_per_sim_s)
