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
The inertial frame, the Earth's orientation and the instants, against SOFA (pyerfa) and astropy.

pyerfa (SOFA's routines, installed with astropy, a test dependency) has the complete IAU 1976
precession, IAU 1980 nutation, GMST 1982, the equation of the equinoxes and the ERA: ours must be
those, except the 72 smallest nutation terms left out (0.01 arcsec). astropy's TEME -> GCRS (IAU
2006/2000A with its shipped Earth orientation tables, offline) bounds what the IAU 1976/1980
frame and the frame bias cost together. The kernels are held to the numpy path to rounding.
"""

from __future__ import annotations

import datetime
import math
import os

import numpy as np
import pytest
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.environment import earth, epochs
from torquefree_ros.core.environment import environment_kernels as kernels
from torquefree_ros.core.numerics import kernels as switch

erfa = pytest.importorskip('erfa')

ARCSECOND = math.pi / 648000.0
EPS = np.finfo(float).eps
J2000 = epochs.J2000_JD
needs_numba = pytest.mark.skipif(not switch.AVAILABLE and not os.environ.get('CI'),
                                 reason='numba (the fast extra) is not installed')


def _instants(count=2001):
    return np.linspace(epochs.utc_seconds('1970-01-01'), epochs.utc_seconds('2035-01-01'), count)


def _tt_days(seconds):
    return (seconds + kernels.TT_MINUS_UTC) / 86400.0


def _angle(a, b):
    """Return the rotation angle between rotation matrices ``a`` and ``b``, rad (stable near 0)."""
    difference = a @ np.swapaxes(b, -1, -2)
    skew = np.stack([difference[..., 2, 1] - difference[..., 1, 2],
                     difference[..., 0, 2] - difference[..., 2, 0],
                     difference[..., 1, 0] - difference[..., 0, 1]], axis=-1)
    return np.arctan2(0.5 * np.linalg.norm(skew, axis=-1),
                      0.5 * (np.trace(difference, axis1=-2, axis2=-1) - 1.0))


def test_precession_and_the_mean_obliquity_are_sofas():
    seconds = _instants()
    assert np.abs(earth.precession_matrix(seconds) - erfa.pmat76(J2000, _tt_days(seconds))).max() \
        <= 4 * EPS
    assert np.abs(earth.mean_obliquity(seconds) - erfa.obl80(J2000, _tt_days(seconds))).max() \
        <= 4 * EPS


def test_nutation_is_sofas_series_less_its_smallest_terms():
    seconds = _instants()
    dpsi, deps = earth.nutation(seconds)
    full_dpsi, full_deps = erfa.nut80(J2000, _tt_days(seconds))
    # the 72 terms left out: 0.009 and 0.003 arcsec measured over 1970-2035
    assert np.abs(dpsi - full_dpsi).max() <= 0.012 * ARCSECOND
    assert np.abs(deps - full_deps).max() <= 0.005 * ARCSECOND
    assert np.abs(earth.equation_of_equinoxes(seconds)
                  - erfa.eqeq94(J2000, _tt_days(seconds))).max() <= 0.012 * ARCSECOND


def test_sidereal_time_and_the_earth_rotation_angle_are_sofas():
    seconds = _instants()
    days = seconds / 86400.0
    # UT1 = UTC on both sides; float64 of a day's fraction: ~1e-11 rad
    for ours, theirs in ((earth.gmst(seconds), erfa.gmst82(J2000, days)),
                         (earth.earth_rotation_angle(seconds), erfa.era00(J2000, days))):
        assert np.abs(np.angle(np.exp(1j * (ours - theirs)))).max() <= 1e-10
    assert np.all((earth.gmst(seconds) >= 0.0) & (earth.gmst(seconds) < 2.0 * math.pi))


def test_the_earth_fixed_matrix_is_sofas_equinox_based_one():
    seconds = _instants(401)
    theirs = erfa.c2teqx(erfa.pnm80(J2000, _tt_days(seconds)),
                         erfa.gst94(J2000, seconds / 86400.0), np.eye(3))
    # the nutation terms left out, and nothing else
    assert _angle(earth.earth_fixed_matrix(seconds), theirs).max() <= 0.015 * ARCSECOND
    vectors = np.random.default_rng(3).normal(size=(401, 3))
    assert np.allclose(earth.from_earth_fixed(earth.to_earth_fixed(vectors, seconds), seconds),
                       vectors, rtol=0.0, atol=16 * EPS * 4)


def test_teme_reaches_the_gcrs_within_the_frames_stated_error():
    astropy_coordinates = pytest.importorskip('astropy.coordinates')
    from astropy import units
    from astropy.time import Time
    from astropy.utils import iers

    # offline: astropy's shipped Earth orientation tables, no download
    iers.conf.auto_download = False
    rng = np.random.default_rng(2)
    seconds = rng.uniform(epochs.utc_seconds('1995-01-01'), epochs.utc_seconds('2026-06-01'), 40)
    vectors = rng.normal(size=(40, 3))
    vectors /= np.linalg.norm(vectors, axis=1)[:, None]
    when = Time([epochs.utc_datetime(s).replace(tzinfo=None) for s in seconds], scale='utc')
    teme = astropy_coordinates.TEME(
        astropy_coordinates.CartesianRepresentation(vectors.T * units.km), obstime=when
    )
    gcrs = teme.transform_to(astropy_coordinates.GCRS(obstime=when)).cartesian.xyz.value.T
    ours = np.einsum('nij,nj->ni', earth.teme_matrix(seconds), vectors)
    angle = np.linalg.norm(np.cross(ours, gcrs), axis=1)
    # the frame bias (0.023") + IAU 1976/1980 against IAU 2006/2000A and the measured pole
    # offsets (~0.05") + the nutation terms left out (0.01"): measured 0.044" at most
    assert angle.max() <= 0.1 * ARCSECOND


@needs_numba
def test_a_place_gives_the_frame_at_scene_times_on_both_paths(monkeypatch):
    from torquefree_ros.core.environment.orbit import KeplerOrbit
    from torquefree_ros.core.environment.place import Place
    from torquefree_ros.core.numerics import kernels as switch

    place = Place(KeplerOrbit(7.0e6, epoch='2026-03-20T12:00:00Z'), start=_instants(1)[0])
    times = np.linspace(0.0, 86400.0, 12).reshape(3, 4)
    monkeypatch.setattr(switch, 'ENABLED', True)
    compiled, single = place.earth_fixed(times), place.earth_fixed(7.5)
    monkeypatch.setattr(switch, 'ENABLED', False)
    assert compiled.shape == (3, 4, 3, 3) and single.shape == (3, 3)
    # as the kernels' test below: a few ulp of numpy's sin/cos
    assert np.abs(compiled - place.earth_fixed(times)).max() <= 32 * EPS
    assert np.abs(single - place.earth_fixed(7.5)).max() <= 32 * EPS


@needs_numba
def test_the_frame_kernels_equal_the_numpy_path_and_may_be_held_for_an_hour():
    seconds = _instants(41)
    matrices = earth.earth_fixed_matrix(seconds)
    out = np.empty((3, 3))
    celestial = np.empty((3, 3))
    for i, instant in enumerate(seconds):
        kernels.kernel('earth_fixed_matrix')(instant, out)
        # the complex products of the nutation's arguments against numpy's sin/cos: a few ulp
        assert np.abs(out - matrices[i]).max() <= 32 * EPS
        held = kernels.kernel('celestial_matrix')(instant, celestial)
        assert held == pytest.approx(earth.equation_of_equinoxes(instant), rel=0, abs=1e-15)
        for later in (600.0, 3600.0):
            kernels.kernel('earth_fixed_matrix_held')(instant + later, celestial, held, out)
            # precession-nutation held: ~5e-6 arcsec/s at most (0.0097" measured over an hour)
            assert _angle(out, earth.earth_fixed_matrix(instant + later)) <= 0.02 * ARCSECOND


@pytest.mark.parametrize('text, year', [
    ('2000-01-01T00:00:00Z', 2000.0),
    ('2000-07-02T00:00:00Z', 2000.0 + 183.0 / 366.0),
    ('2026-03-20T12:00:00+00:00', 2026.0 + 78.5 / 365.0),
    ('1900-03-01T00:00:00', 1900.0 + 59.0 / 365.0),  # 1900 is not a leap year
    ('2030-01-01', 2030.0),
    ('1899-12-31T18:00:00', 1899.0 + 364.75 / 365.0),
])
def test_the_decimal_year_is_the_calendars(text, year):
    seconds = epochs.utc_seconds(text)
    assert epochs.decimal_year(seconds) == pytest.approx(year, rel=0, abs=1e-12)
    if switch.AVAILABLE:
        assert kernels.kernel('decimal_year')(seconds) == epochs.decimal_year(seconds)


def test_instants_parse_in_every_documented_form():
    noon = epochs.utc_seconds('2026-03-20T12:00:00Z')
    assert noon == epochs.utc_seconds(datetime.datetime(2026, 3, 20, 12))
    assert noon == epochs.utc_seconds('2026-03-20T14:00:00+02:00')
    assert noon - 43200.0 == epochs.utc_seconds(datetime.date(2026, 3, 20))
    assert epochs.utc_seconds('2000-01-01T12:00:00Z') == 0.0
    for bad in ('tomorrow', 20260320, None):
        with pytest.raises(FieldError, match=r'scene\.epoch: expected an ISO 8601'):
            epochs.utc_seconds(bad, 'scene.epoch')
