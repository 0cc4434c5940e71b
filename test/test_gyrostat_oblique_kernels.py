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
The oblique gyrostat's compiled evaluation (numba) against the numpy path it repeats.

The kernels repeat numpy's operations in numpy's order, so the two differ only where a
function's own last bit does (numpy's vectorised ``sin``, ``cos``, ``tanh``, ``cosh`` against the
C library's) and in the order of three-term dot products. The closed form carries such a change
of ``sn, cn, dn`` into ``m`` amplified by its own conditioning at that sample: a few units on the
reference cases (measured at most 11.3 rounding units of the rates' scale and of ``|m|``, and
2.2 ``eps (16 + |w| t)`` of attitude, the angle ``psi ~ |w| t`` carrying its rounding), up to
136 units of ``|m|`` on some random motions (one rounding unit of ``sn`` alone moves the numpy
path's ``m`` by 124 units at such a sample: the formula's, not the kernel's). The tolerances sit
above those with the reason beside each. Accuracy itself: test_gyrostat_oblique.py against
mpmath, which runs on the compiled path by default and on numpy's with
``TORQUEFREE_ROS_KERNELS=numpy``.
"""

from __future__ import annotations

import json
from pathlib import Path

from conftest import require_numba
import numpy as np
import pytest
import torquefree_ros.bench
from torquefree_ros.core.exact.gyrostat_oblique import (
    BASE_POINT_MARGIN,
    ObliqueAttitude,
    ObliqueRateIntegrals,
    PeriodicIntegral,
    solve_oblique,
)
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.run.accuracy import trajectory_errors

EPS = np.finfo(float).eps

OBLIQUE = json.loads((Path(__file__).parent / 'data' / 'gyrostat_oblique_cases.json').read_text())
PRINCIPAL = json.loads(
    Path(torquefree_ros.bench.__file__).with_name('gyrostat_cases.json').read_text()
)


def _principal_h(case):
    axis = np.asarray(case['rotor']['axis'], dtype=float)
    return case['rotor']['momentum'] * axis / np.linalg.norm(axis)


#: name: (moments, w0, h, q0, horizon), the oblique references and the principal-axis ones
CASES = {
    case['name']: (
        case['inertia'], case['angular_velocity'], case['rotor_vector'], case['orientation'],
        case['times'][-1],
    )
    for case in OBLIQUE['cases']
} | {
    case['name']: (
        case['inertia'], case['angular_velocity'], _principal_h(case), case['orientation'],
        case['times'][-1],
    )
    for case in PRINCIPAL['cases']
    if 'rotor' in case and case['name'] != 'symmetric_rotor_on_axis'
}


def _random_states(count, seed=11):
    """Seeded motions: moments in [0.5, 5], rates in [-3, 3] rad/s, ``|h|`` up to 5 any way."""
    rng = np.random.default_rng(seed)
    states = []
    for _ in range(count):
        moments, w = rng.uniform(0.5, 5.0, 3), rng.uniform(-3.0, 3.0, 3)
        h = rng.normal(size=3) * rng.uniform(0.0, 5.0)
        q = rng.normal(size=4)
        states.append((moments, w, h, q / np.linalg.norm(q), 1e3))
    return states


@pytest.fixture(autouse=True)
def _numba():
    if not switch.AVAILABLE:
        require_numba()


def _both_paths(monkeypatch, state, times):
    """Return ``{compiled: (omega_B, q, w_P, m_P, v, attitude)}`` from one solved motion."""
    moments, w0, h, q0, _ = state
    motion = solve_oblique(moments, w0, h)
    runs = {}
    for compiled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', compiled)
        attitude = ObliqueAttitude(motion, h, np.eye(3), q0)
        assert attitude.compiled is compiled
        omega, q = attitude(times)
        w, m = attitude.rates.state(times)
        runs[compiled] = (omega, q, w, m, attitude.rates.momentum_direction(times), attitude)
    return motion, runs


def _differences(motion, runs, times):
    """Return the differences in rounding units: rates, momentum, attitude (see the module)."""
    (omega, q, w, m, v, _), (omega_n, q_n, w_n, m_n, v_n, _) = runs[True], runs[False]
    # w = w0 + A (m - m0): rounded in units of the larger of |w| and |m| max(A)
    scale = max(np.abs(w_n).max(), np.abs(m_n).max() * max(motion.inverse_moments))
    rate = max(np.abs(w - w_n).max(), np.abs(omega - omega_n).max()) / (EPS * scale)
    momentum = np.abs(m - m_n).max() / (EPS * np.abs(m_n).max())
    _, angle = trajectory_errors(omega, q, omega_n, q_n)
    attitude = (angle / (EPS * (16.0 + np.linalg.norm(w_n, axis=1) * times))).max()
    # the direction v itself, scaled to unit length (its size is arbitrary)
    unit, unit_n = (x / np.linalg.norm(x, axis=1)[:, None] for x in (v, v_n))
    direction = np.abs(unit - unit_n).max()
    return rate, momentum, attitude, direction


@pytest.mark.parametrize('name', sorted(CASES))
def test_the_kernel_repeats_the_numpy_path_on_the_reference_cases(name, monkeypatch):
    """
    Rates and ``m`` within 32 rounding units of their scales, attitude within 4.

    (Measured 11.3, 11.3 and 2.2: libm's last bits through the closed form, module docstring.)
    The direction ``v`` within 1e-13 (unit length; its angle to the motion's ``m`` is well
    conditioned but the pencil's coordinates next to a saddle are not: 89 units measured).
    """
    state = CASES[name]
    times = np.linspace(0.0, state[-1], 2001)
    motion, runs = _both_paths(monkeypatch, state, times)
    rate, momentum, attitude, direction = _differences(motion, runs, times)
    assert rate <= 32.0 and momentum <= 32.0 and attitude <= 4.0, (rate, momentum, attitude)
    assert direction <= 1e-13


@pytest.mark.parametrize('index, state', list(enumerate(_random_states(20))))
def test_the_kernel_repeats_the_numpy_path_on_random_motions(index, state, monkeypatch):
    """
    Seeded random moments, rates and ``h``: within the closed form's own conditioning.

    Rates within 128 rounding units of their scale, ``m`` within 512 of ``|m|``, attitude within
    4: measured at most 35, 136 and 1.3, where one rounding unit of ``sn`` alone moves the numpy
    path's ``m`` by 124 units (module docstring). A wrong constant or operation moves them by
    far more than that.
    """
    times = np.linspace(0.0, state[-1], 2001)
    motion, runs = _both_paths(monkeypatch, state, times)
    rate, momentum, attitude, _ = _differences(motion, runs, times)
    assert rate <= 128.0 and momentum <= 512.0 and attitude <= 4.0, (rate, momentum, attitude)


@pytest.mark.parametrize('name', ['oblique_generic', 'oblique_separatrix_one_saddle_below_1e-10'])
def test_the_base_points_form_is_compiled_too(name, monkeypatch):
    """
    Samples next to the pencil's base point (times by multiples of the period) take its form.

    The turning point's form hands those samples to the initial point's form: both paths agree
    there within the reference cases' bounds (above), at every such sample.
    """
    state = CASES[name]
    motion = solve_oblique(*state[:3])
    times = np.concatenate(
        [k * motion.period + motion.base_time + np.linspace(-1e-3, 1e-3, 41) * motion.period
         for k in range(1, 4)]
    )
    _, runs = _both_paths(monkeypatch, state, times)
    v = runs[False][4]
    along = np.abs(v @ np.asarray(motion.tangent)) / np.linalg.norm(v, axis=1)
    assert np.count_nonzero(along**2 > 1.0 - BASE_POINT_MARGIN**2) >= 6  # the form is reached
    rate, momentum, attitude, _ = _differences(motion, runs, times)
    assert rate <= 32.0 and momentum <= 32.0 and attitude <= 4.0, (rate, momentum, attitude)


@pytest.mark.parametrize('name', ['oblique_separatrix_exact', 'oblique_separatrix_exact_one_root'])
def test_on_a_separatrix_the_kernel_repeats_the_numpy_path_to_long_times(name, monkeypatch):
    """
    ``mc = 0`` (``sn = tanh``, ``cn = dn = sech``, the angle's series in ``tanh``) out to 1e5 s.

    Both ways in time, through the saddle's approach where ``sech`` underflows: within the
    reference cases' bounds (above).
    """
    state = CASES[name]
    times = np.concatenate([-np.geomspace(1e5, 1.0, 200), np.linspace(0.0, 40.0, 401),
                            np.geomspace(40.0, 1e5, 200)])
    motion, runs = _both_paths(monkeypatch, state, times)
    assert motion.mc == 0.0
    rate, momentum, attitude, _ = _differences(motion, runs, np.abs(times))
    assert rate <= 32.0 and momentum <= 32.0 and attitude <= 4.0, (rate, momentum, attitude)


def test_samples_do_not_depend_on_how_they_are_requested(monkeypatch):
    """The node asks in blocks, offline tools all at once: the compiled samples are identical."""
    monkeypatch.setattr(switch, 'ENABLED', True)
    moments, w0, h, q0, horizon = CASES['oblique_generic']
    attitude = ObliqueAttitude(solve_oblique(moments, w0, h), h, np.eye(3), q0)
    times = np.linspace(0.0, horizon, 301)
    whole = attitude(times)
    blocks = [attitude(chunk) for chunk in np.array_split(times, 7)]
    for k in range(2):
        np.testing.assert_array_equal(np.concatenate([b[k] for b in blocks]), whole[k])


WHEEL_CASES = {case['name']: case for case in PRINCIPAL['cases'] if 'wheels' in case}


@pytest.mark.parametrize('name', sorted(WHEEL_CASES))
def test_the_wheel_angles_repeat_the_numpy_path(name, monkeypatch):
    """
    Coasting wheels' angles from the rates' series, out to 1e5 s: within ``8 eps (1 + |w| t)``.

    The compiled series is numpy's to the bit on the same coefficients, but each path builds its
    series from its own rates, which differ in their last bits: the mean rate's rounding times
    ``t`` (measured at most 1.1 of those units).
    """
    case = WHEEL_CASES[name]
    h = np.asarray(case['gyrostat_momentum'])
    motion = solve_oblique(case['gyrostat_inertia'], case['angular_velocity'], h)
    axes = np.array([np.asarray(w['axis'], float) for w in case['wheels']])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    spins = np.array([w['speed'] for w in case['wheels']]) + axes @ case['angular_velocity']
    times = np.concatenate([np.linspace(0.0, 50.0, 501), np.linspace(50.0, 1e5, 501)])
    runs = {}
    for compiled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', compiled)
        attitude = ObliqueAttitude(motion, h, np.eye(3), case['orientation'])
        integrals = ObliqueRateIntegrals(attitude.rates)
        series = integrals.series  # on a separatrix a WholeLineIntegral's series in tanh
        series = series if isinstance(series, PeriodicIntegral) else series.series
        assert (series._kernel is not None) is compiled
        runs[compiled] = integrals.wheel_angles(times, axes, spins)
    speed = np.linalg.norm(attitude.rates(times), axis=1).max()
    bound = 8.0 * EPS * (1.0 + speed * times)[:, None]
    assert np.all(np.abs(runs[True] - runs[False]) <= bound)
