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
IGRF-14 and the tilted dipole against ppigrf, a second implementation (pure Python, pandas).

ppigrf evaluates the same released coefficients with Legendre functions in spherical coordinates
(ours: Cartesian solid harmonics), so the two agree to rounding at the model's epochs. Between
epochs ppigrf interpolates linearly in elapsed days, the IGRF (and this package) in decimal years:
the fraction differs by up to ~0.4 day in 5 years, worth up to 0.1 nT; hence 0.2 nT there (the
issue asks for 1 nT). The compiled kernels are held to the numpy path to rounding.
"""

from __future__ import annotations

import datetime
import math
import os
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.environment import earth, epochs, magnetic
from torquefree_ros.core.environment import environment_kernels as kernels
from torquefree_ros.core.numerics import kernels as switch

ppigrf = pytest.importorskip('ppigrf')

REPO = Path(__file__).resolve().parents[1]
EPS = np.finfo(float).eps
needs_numba = pytest.mark.skipif(not switch.AVAILABLE and not os.environ.get('CI'),
                                 reason='numba (the fast extra) is not installed')


def _points(count, seed=41, low=6.3e6, high=4.2e7):
    """Random points from the surface to beyond GEO, the poles' neighbourhoods included."""
    rng = np.random.default_rng(seed)
    r = rng.uniform(low, high, count)
    colatitude = np.arccos(rng.uniform(-0.9999, 0.9999, count))
    longitude = rng.uniform(-math.pi, math.pi, count)
    position = np.stack([
        r * np.sin(colatitude) * np.cos(longitude),
        r * np.sin(colatitude) * np.sin(longitude),
        r * np.cos(colatitude),
    ], axis=-1)
    return position, r, colatitude, longitude


def _ppigrf_ned(r, colatitude, longitude, when, max_degree=13):
    """Return ppigrf's geocentric field as north, east, down, T."""
    with np.errstate(all='ignore'):  # ppigrf's own arithmetic, not ours
        radial, south, east = ppigrf.igrf_gc(r / 1e3, np.degrees(colatitude),
                                             np.degrees(longitude), when, max_degree=max_degree)
    return np.stack([-south[0], east[0], -radial[0]], axis=-1) * 1e-9


@pytest.mark.parametrize('when, tolerance_nT', [
    ('1900-01-01T00:00:00', 1e-6),
    ('1965-01-01T00:00:00', 1e-6),
    ('2020-01-01T00:00:00', 1e-6),
    ('2025-01-01T00:00:00', 1e-6),
    ('1957-07-01T06:00:00', 0.2),
    ('2012-03-04T05:06:07', 0.2),
    ('2026-03-20T12:00:00', 0.2),
    ('2029-12-31T00:00:00', 0.2),
])
def test_igrf_matches_ppigrf(when, tolerance_nT):
    position, r, colatitude, longitude = _points(300)
    ours = magnetic.igrf_ned(position, epochs.utc_seconds(when))
    theirs = _ppigrf_ned(r, colatitude, longitude, datetime.datetime.fromisoformat(when))
    assert np.abs(ours - theirs).max() <= tolerance_nT * 1e-9
    # and the field is the Earth's: 20 000 to 70 000 nT at the surface, falling as 1/r^3
    surface = magnetic.igrf_ned(position / r[:, None] * 6371.2e3, epochs.utc_seconds(when))
    strength = np.linalg.norm(surface, axis=-1)
    assert 2.0e-5 <= strength.min() and strength.max() <= 7.0e-5


def test_the_dipole_is_igrfs_degree_one():
    position, r, colatitude, longitude = _points(200, seed=7)
    when = '2026-03-20T12:00:00'
    ours = magnetic.dipole_earth_fixed(position, epochs.utc_seconds(when))
    theirs = _ppigrf_ned(r, colatitude, longitude, datetime.datetime.fromisoformat(when), 1)
    ned = np.einsum('nij,nj->ni', magnetic.ned_axes(position), ours)
    assert np.abs(ned - theirs).max() <= 0.2e-9
    # at 2025.0 its moment is 4 pi a^3 |g1| / mu0 = 7.69e22 A m^2 (g10, g11, h11 of IGRF-14)
    moment = 1e7 * 6371.2e3**3 * math.sqrt(29350.0**2 + 1410.3**2 + 4545.5**2) * 1e-9
    assert moment == pytest.approx(7.69e22, rel=1e-3)
    above_pole = magnetic.dipole_earth_fixed([0.0, 0.0, 1e8], epochs.utc_seconds('2025-01-01'))
    assert np.linalg.norm(above_pole) == pytest.approx(
        1e-7 * moment / 1e8**3 * math.sqrt(1.0 + 3.0 * (29350.0 / 29733.8) ** 2), rel=1e-3
    )


def test_the_poles_are_ordinary_points():
    when = epochs.utc_seconds('2026-01-01')
    for z in (7.0e6, -7.0e6):
        pole = magnetic.igrf_earth_fixed([0.0, 0.0, z], when)
        near = magnetic.igrf_earth_fixed([1e-3, 1e-3, z], when)  # 1.4 mm off the axis
        assert np.all(np.isfinite(pole))
        # the field's gradient is ~3 |B| / r: 1.4 mm moves it by ~6e-10 of |B| at 7000 km
        assert np.abs(pole - near).max() <= 2e-9 * np.linalg.norm(pole)


def test_the_inertial_field_is_the_earth_fixed_field_rotated():
    rng = np.random.default_rng(5)
    seconds = epochs.utc_seconds('2026-03-20') + rng.uniform(0.0, 86400.0 * 30, 50)
    position_N, _, _, _ = _points(50, seed=6)
    inertial = magnetic.igrf_inertial(position_N, seconds)
    matrix = earth.earth_fixed_matrix(seconds)
    fixed = magnetic.igrf_earth_fixed(np.einsum('nij,nj->ni', matrix, position_N), seconds)
    # two rotations of a vector: a few roundings of |B|
    scale = np.linalg.norm(fixed, axis=-1, keepdims=True)
    assert np.all(np.abs(np.einsum('nij,nj->ni', matrix, inertial) - fixed) <= 8 * EPS * scale)
    assert magnetic.igrf_inertial(position_N[0], seconds[0]).shape == (3,)


@pytest.mark.parametrize('when', ['1899-12-31T23:00:00', '2030-01-01T00:00:01', '2100-01-01'])
def test_instants_outside_the_model_are_refused(when):
    with pytest.raises(FieldError) as raised:
        magnetic.igrf_earth_fixed([7e6, 0.0, 0.0], epochs.utc_seconds(when), path='orbit.epoch')
    assert raised.value.path == 'orbit.epoch'
    assert 'IGRF-14 covers 1900.0 to 2030.0' in str(raised.value)
    with pytest.raises(FieldError, match='IGRF-14 covers'):
        magnetic.dipole_inertial([7e6, 0.0, 0.0], epochs.utc_seconds(when))
    with pytest.raises(FieldError, match='finite'):
        magnetic.igrf_inertial([7e6, 0.0, 0.0], math.nan)
    # the model's ends are inside it
    for end in ('1900-01-01T00:00:00', '2030-01-01T00:00:00'):
        assert np.all(np.isfinite(magnetic.igrf_earth_fixed([7e6, 0, 0], epochs.utc_seconds(end))))


def test_the_quick_range_check_agrees_with_the_decimal_years():
    """``years=False`` refuses what the decimal years refuse, up to the bounds' rounding."""
    for bound in (magnetic.FIRST_INSTANT, magnetic.LAST_INSTANT):
        assert bound == epochs.utc_seconds(
            '1900-01-01T00:00:00' if bound < 0 else '2030-01-01T00:00:00'
        )
        # around each bound, down to the instants' own spacing there
        spacing = np.spacing(abs(bound))
        for offset in (-1.0, -1e-3, -spacing, 0.0, spacing, 1e-3, 1.0):
            instant = bound + offset
            try:
                magnetic.check_instants(instant)
                inside = True
            except FieldError:
                inside = False
            if inside:  # (the years decide where the bounds' rounding does)
                magnetic.check_instants(instant, years=False)
            else:
                with pytest.raises(FieldError, match='IGRF-14 covers'):
                    magnetic.check_instants(instant, years=False)


@needs_numba
def test_the_compiled_kernels_equal_the_numpy_path():
    position, _, _, _ = _points(60, seed=11)
    rng = np.random.default_rng(12)
    seconds = rng.uniform(epochs.utc_seconds('1900-01-01'), epochs.utc_seconds('2030-01-01'), 60)
    table = magnetic.kernel_table()
    years = epochs.decimal_year(seconds)
    references = {
        'igrf_earth_fixed': magnetic.igrf_earth_fixed(position, seconds),
        'dipole_earth_fixed': magnetic.dipole_earth_fixed(position, seconds),
        'igrf_inertial': magnetic.igrf_inertial(position, seconds),
        'dipole_inertial': magnetic.dipole_inertial(position, seconds),
    }
    out = np.empty(3)
    for name, reference in references.items():
        kernel = kernels.kernel(name)
        for i in range(len(seconds)):
            if name.endswith('earth_fixed'):
                kernel(*position[i], years[i], table, out)
            else:
                kernel(position[i], seconds[i], table, out)
            # the same operations in the same order; the inertial ones go through the frame's
            # sines and cosines (libm's and numpy's may differ in the last bit)
            bound = 16 * EPS * np.linalg.norm(reference[i])
            assert np.abs(out - reference[i]).max() <= bound, name
    assert kernels.kernel('decimal_year')(seconds[0]) == years[0]
    kernels.kernel('igrf_earth_fixed')(7e6, 0.0, 0.0, 2030.5, table, out)
    assert np.all(np.isnan(out))  # outside the table: NaN (callers check first)


def test_the_shipped_table_is_the_released_one():
    """tools/make_igrf14_table.py regenerates the table from ppigrf's IGRF14.shc, unchanged."""
    result = subprocess.run(
        [sys.executable, str(REPO / 'tools' / 'make_igrf14_table.py'), '--check'],
        capture_output=True, text=True, timeout=120,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    # IGRF-14's 2025.0 dipole and its secular variation (the release: g10 -29350.0, 12.6 nT/yr)
    table = magnetic.schmidt_table()
    assert table[25, 0, 1, 0] == -29350.0 and table[26, 0, 1, 0] - table[25, 0, 1, 0] == 63.0
