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
A stranger's install: the wheel of this checkout in a clean virtual environment.

Installed into a clean virtual environment (no system packages), the wheel pulls every runtime
dependency, and the documented console scripts and API work there. Versions come from
requirements.lock; pip's cache makes this take under a minute.
"""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys
import venv

import pytest

REPO = Path(__file__).resolve().parent.parent
TIMEOUT = 600  # s: a cold pip cache downloads the ROS wheels


def _run(argv, cwd, timeout=120, env_extra=None):
    env = None if env_extra is None else {**os.environ, **env_extra}
    result = subprocess.run(
        [str(a) for a in argv], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env
    )
    assert result.returncode == 0, f'{argv}: {result.stdout}\n{result.stderr}'
    return result


def test_the_wheel_installs_into_a_clean_venv_with_every_runtime_dependency(tmp_path):
    _run(
        [
            sys.executable,
            '-m',
            'pip',
            'wheel',
            '--quiet',
            '--no-deps',
            '--no-build-isolation',
            '-w',
            tmp_path / 'dist',
            REPO,
        ],
        cwd=tmp_path,
        timeout=TIMEOUT,
    )
    (wheel,) = (tmp_path / 'dist').glob('torquefree_ros-*.whl')
    venv.create(tmp_path / 'venv', with_pip=True)  # no --system-site-packages: nothing leaks in
    bin_dir = tmp_path / 'venv' / 'bin'
    # the README's install line with the plot extra, from a wheel instead of the source tree
    _run(
        [
            bin_dir / 'pip',
            'install',
            '--quiet',
            '--disable-pip-version-check',
            '-c',
            REPO / 'requirements.lock',
            f'{wheel}[plot]',
        ],
        cwd=tmp_path,
        timeout=TIMEOUT,
    )

    csv = _run(
        [bin_dir / 'torquefree_propagate', '--duration', '1', '--rate', '2'], cwd=tmp_path
    ).stdout
    assert csv.splitlines()[0] == 't,w_x,w_y,w_z,q_x,q_y,q_z,q_w' and len(csv.splitlines()) == 4
    _run(
        [
            bin_dir / 'torquefree_bag',
            'explorer1',
            '--duration',
            '1',
            '--rate',
            '10',
            '--output',
            'bag',
        ],
        cwd=tmp_path,
    )
    assert sorted(p.name for p in (tmp_path / 'bag').iterdir()) == ['bag_0.mcap', 'metadata.yaml']
    _run([bin_dir / 'torquefree_plot', 'bag', '--output-dir', 'plots'], cwd=tmp_path)
    assert (tmp_path / 'plots' / 'bag_polhode.png').stat().st_size > 10_000
    assert (
        "record_bag (default ''"
        in _run([bin_dir / 'torquefree_sim', '--help'], cwd=tmp_path).stdout
    )
    api = (
        "import torquefree_ros as t; s = t.load_scene('dzhanibekov'); "
        'w, q = t.propagate(s.inertia, s.angular_velocity, s.orientation, [0.0, 1.0]); '
        'print(q.shape)'
    )
    assert _run([bin_dir / 'python', '-c', api], cwd=tmp_path).stdout.strip() == '(2, 4)'
    # numba came with the plain install: the kernels are on, compiled in the installed package
    # (numba's cache beside it), and give what the numpy/scipy reference path gives
    kernels = (
        'from torquefree_ros.core.numerics import kernels; print(kernels.ENABLED)'
    )
    assert _run([bin_dir / 'python', '-c', kernels], cwd=tmp_path).stdout.strip() == 'True'
    reference = _run(
        [bin_dir / 'torquefree_propagate', '--duration', '1', '--rate', '2'],
        cwd=tmp_path,
        env_extra={'TORQUEFREE_ROS_KERNELS': 'numpy'},
    ).stdout
    for row, row_reference in zip(csv.splitlines()[1:], reference.splitlines()[1:]):
        assert [float(v) for v in row.split(',')] == pytest.approx(
            [float(v) for v in row_reference.split(',')], abs=1e-14
        )
    # a scene with an effect, on both paths (explorer1: a damper, DOP853 at 1e-9)
    effects = (
        "import torquefree_ros as t; p = t.load_scene('explorer1').propagator(); "
        'w, q = p([0.0, 10.0]); print(p.compiled, *w[-1], *q[-1])'
    )
    fast = _run([bin_dir / 'python', '-c', effects], cwd=tmp_path).stdout.split()
    slow = _run(
        [bin_dir / 'python', '-c', effects],
        cwd=tmp_path,
        env_extra={'TORQUEFREE_ROS_KERNELS': 'numpy'},
    ).stdout.split()
    assert fast[0] == 'True' and slow[0] == 'False'
    # the same steps but for rounding in a few sums: far inside the 1e-9 tolerance
    assert [float(v) for v in fast[1:]] == pytest.approx([float(v) for v in slow[1:]], abs=1e-11)
    # the fast extra still installs (it names numba, already there)
    _run(
        [
            bin_dir / 'pip',
            'install',
            '--quiet',
            '--disable-pip-version-check',
            '-c',
            REPO / 'requirements.lock',
            f'{wheel}[fast]',
        ],
        cwd=tmp_path,
        timeout=TIMEOUT,
    )
