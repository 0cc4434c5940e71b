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
The Sun: a low-precision ephemeris, and the Earth's shadow (umbra and penumbra).

**The ephemeris** is Meeus's low-accuracy solar position (*Astronomical Algorithms*, 2nd ed.,
1998, ch. 25, after Newcomb; the Astronomical Almanac's low-precision formula is its truncation),
``T`` TT centuries since J2000.0:

- geometric mean longitude ``L0 = 280.46646 + 36000.76983 T + 0.0003032 T^2`` deg, mean anomaly
  ``M = 357.52911 + 35999.05029 T - 0.0001537 T^2`` deg, the orbit's eccentricity ``e =
  0.016708634 - 0.000042037 T - 0.0000001267 T^2``;
- the equation of the centre ``C = (1.914602 - 0.004817 T - 0.000014 T^2) sin M + (0.019993 -
  0.000101 T) sin 2M + 0.000289 sin 3M`` deg; the longitude ``L0 + C - 0.00569`` deg (the
  annual aberration; the ecliptic latitude, below 1.2 arcsec, is 0); the distance ``1.000001018
  (1 - e^2) / (1 + e cos(M + C))`` au;
- in the mean equator and equinox of date (the IAU 1980 mean obliquity; nutation is not
  applied, the frame being a mean one), rotated to EME2000 by IAU 1976 precession's transpose.

These are the Sun's *apparent* coordinates (light time and aberration in, as a sensor sees it),
stated to 0.01 deg. Against astropy's apparent GCRS Sun the direction is within 0.0096 deg and
the distance within 8e-5 au over 1950-2050 (test/test_sun.py); the Sun's own parallax seen from
LEO (7000 km / 1 au, 10 arcsec) is for the caller (:func:`sun_from`).

**The shadow** is that of a spherical Earth (WGS 84's equatorial radius) on a spherical Sun
(IAU's nominal radius 695 700 km), conical: seen from the point, the Sun's disc has apparent
radius ``a = asin(R_sun / |s - r|)``, the Earth's ``b = asin(R_earth / |r|)``, their centres are
``c`` apart; the point is lit for ``c >= a + b``, in the umbra for ``c <= b - a``, annular for ``c
<= a - b``, and in between the hidden fraction is the overlap of two plane discs of radii ``a``,
``b`` at distance ``c`` over the Sun's (Montenbruck and Gill, *Satellite Orbits*, 2000, 3.4).
The boundaries are exact for the two spheres (the cones tangent to both); the fraction is the
plane-disc approximation with a uniformly bright disc (no limb darkening), within 5e-4 of an
exact count of rays to the Sun's disc in LEO (test/test_sun.py). Left out: the Earth's
flattening (21 km less at the poles: an entry or exit up to ~3 s off at high latitude) and its
atmosphere (refraction and absorption spread the edge over some seconds).
"""

from __future__ import annotations

import numpy as np

from . import earth, epochs
from . import environment_kernels as _k

#: the Sun's nominal radius, m (IAU 2015 Resolution B3)
SUN_RADIUS = _k.SUN_RADIUS
#: the astronomical unit, m (IAU 2012 Resolution B2)
ASTRONOMICAL_UNIT = _k.ASTRONOMICAL_UNIT


def sun_position(seconds) -> np.ndarray:
    """
    Return the Sun's geocentric position (m, inertial) at the UTC instants ``seconds``.

    Shape ``seconds.shape + (3,)``.
    """
    seconds = np.asarray(seconds, dtype=float)
    t = epochs.julian_centuries_tt(seconds)
    mean_longitude = np.fmod((0.0003032 * t + 36000.76983) * t + 280.46646, 360.0)
    anomaly = np.deg2rad(np.fmod((-0.0001537 * t + 35999.05029) * t + 357.52911, 360.0))
    e = (-0.0000001267 * t - 0.000042037) * t + 0.016708634
    centre = (((-0.000014 * t - 0.004817) * t + 1.914602) * np.sin(anomaly)
              + (-0.000101 * t + 0.019993) * np.sin(2.0 * anomaly)
              + 0.000289 * np.sin(3.0 * anomaly))
    longitude = np.deg2rad(mean_longitude + centre - _k.ABERRATION_DEGREES)
    distance = 1.000001018 * (1.0 - e * e) / (1.0 + e * np.cos(anomaly + np.deg2rad(centre))) \
        * ASTRONOMICAL_UNIT
    obliquity = earth.mean_obliquity(seconds)
    date = np.stack([
        distance * np.cos(longitude),
        distance * np.cos(obliquity) * np.sin(longitude),
        distance * np.sin(obliquity) * np.sin(longitude),
    ], axis=-1)
    # mean of date -> EME2000: the transpose of precession
    return np.einsum('...ji,...j->...i', earth.precession_matrix(seconds), date)


def sun_direction(seconds):
    """Return the Sun's unit vector (inertial) and distance (m) from the Earth's centre."""
    position = sun_position(seconds)
    distance = np.sqrt((position * position).sum(axis=-1))
    return position / distance[..., None], distance


def sun_from(position_N, seconds):
    """
    Return the Sun's unit vector and distance (m) from the inertial ``position_N`` (m).

    The direction a sun sensor at that point sees (the Earth-centre direction plus the parallax,
    up to 10 arcsec in LEO).
    """
    relative = sun_position(seconds) - np.asarray(position_N, dtype=float)
    distance = np.sqrt((relative * relative).sum(axis=-1))
    return relative / distance[..., None], distance


def shadow_fraction(position_N, sun_N) -> np.ndarray:
    """
    Return the fraction of the Sun's disc the Earth hides from ``position_N`` (m): 0 lit, 1 umbra.

    ``sun_N``: the Sun's geocentric position (m, same frame; :func:`sun_position`); shapes
    ``(..., 3)``, broadcast. A point inside the Earth gets 1.
    """
    position = np.asarray(position_N, dtype=float)
    sun = np.asarray(sun_N, dtype=float)
    position, sun = np.broadcast_arrays(position, sun)
    r = np.sqrt((position * position).sum(axis=-1))
    relative = sun - position
    d = np.sqrt((relative * relative).sum(axis=-1))
    inside = r <= _k.EQUATORIAL_RADIUS
    a = np.arcsin(SUN_RADIUS / d)
    b = np.arcsin(np.where(inside, 1.0, _k.EQUATORIAL_RADIUS / np.where(inside, 1.0, r)))
    # the angle between the Earth's centre and the Sun, as seen from the point
    cross = np.cross(-position, relative)
    c = np.arctan2(np.sqrt((cross * cross).sum(axis=-1)), -(position * relative).sum(axis=-1))
    lit = c >= a + b
    umbra = c <= b - a
    annular = c <= a - b
    partial = ~(lit | umbra | annular | inside)
    fraction = np.where(umbra | inside, 1.0, 0.0)
    fraction = np.where(annular & ~umbra & ~lit & ~inside, (b * b) / (a * a), fraction)
    if partial.any():
        # the lens as two circular segments (:func:`.environment_kernels.shadow_fraction`)
        ap, bp, cp = a[partial], b[partial], c[partial]
        y = np.sqrt((ap + bp - cp) * (ap - bp + cp) * (bp + cp - ap) * (ap + bp + cp)) / (2.0 * cp)
        phi_a = np.arctan2(y, (cp * cp + ap * ap - bp * bp) / (2.0 * cp))
        phi_b = np.arctan2(y, (cp * cp - ap * ap + bp * bp) / (2.0 * cp))
        area = 0.5 * (ap * ap * _u_minus_sin(2.0 * phi_a) + bp * bp * _u_minus_sin(2.0 * phi_b))
        fraction[partial] = np.minimum(area / (np.pi * ap * ap), 1.0)
    return fraction


def _u_minus_sin(u):
    """``u - sin u`` for ``u >= 0`` without cancellation (the series below 1)."""
    x = u * u
    total = np.zeros_like(u)
    for coefficient in _k.E_MINUS_SIN_SERIES[::-1]:
        total = total * x + coefficient
    return np.where(u >= 1.0, u - np.sin(u), total * x * u)
