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
A Keplerian orbit: exact two-body motion from elements at an epoch, optionally J2's secular drift.

Position and velocity in the inertial frame (EME2000, :mod:`.earth`) at ``t`` seconds since the
elements' epoch. Two-body motion is Kepler's equation ``E - e sin E = M`` solved to float64's
floor for ``0 <= e < 1`` (:func:`eccentric_anomaly`), then the perifocal position and velocity
rotated by ``R3(-RAAN) R1(-i) R3(-omega)`` (Vallado 2013, algorithm 10, COE2RV; the perifocal
form in the eccentric anomaly, Montenbruck and Gill 2000, ch. 2).

With ``j2=True`` the elements are mean elements whose node, perigee and mean anomaly drift at
J2's first-order secular rates (Kozai 1959, AJ 64, 367; Vallado 2013, ch. 9), ``p = a (1 -
e^2)``:

- ``RAAN' = -3/2 n J2 (R/p)^2 cos i``
- ``omega' = 3/4 n J2 (R/p)^2 (4 - 5 sin^2 i)``
- ``M' = n (1 + 3/4 J2 (R/p)^2 sqrt(1 - e^2) (2 - 3 sin^2 i))``

J2's short-period terms (about ``J2 a``, 10 km in LEO) and its long-period ones are not modelled;
the velocity is the two-body velocity on the drifting ellipse (the element rates add O(J2 v),
~10 m/s, to ``dr/dt``). Without J2 the motion is exact two-body motion.

:func:`.environment_kernels.kepler_state` is the same evaluation for one instant, compiled.
"""

from __future__ import annotations

import math

import numpy as np

from . import environment_kernels as _k
from . import epochs
from .earth import EQUATORIAL_RADIUS, GM, J2
from ..checks.schema import boolean, FieldError, fields, number, Param, shown

#: the elements a scene's ``orbit:`` gives (SI: m, rad), checked with field paths
ELEMENTS = {
    'epoch': Param(lambda value, path: epochs.utc_seconds(value, path),
                   description='UTC, ISO 8601'),
    'semi_major_axis': Param(number(positive=True, unit='m')),
    'eccentricity': Param(number(minimum=0.0), 0.0),
    'inclination': Param(number(minimum=0.0, maximum=math.pi, unit='rad'), 0.0),
    'raan': Param(number(unit='rad'), 0.0),
    'argument_of_perigee': Param(number(unit='rad'), 0.0),
    'mean_anomaly': Param(number(unit='rad'), 0.0),
    'j2': Param(boolean, False),
}


def eccentric_anomaly(mean_anomaly, eccentricity):
    """
    Solve Kepler's equation ``E - e sin E = M`` for ``E`` (rad), element-wise, ``0 <= e < 1``.

    :func:`.environment_kernels.kepler_eccentric_anomaly`'s method, vectorised (each element
    iterates until its own stop, as the kernel does); ``E`` is on the same revolution as ``M``
    (``E - M`` in ``[-e, e]``).
    """
    mean_anomaly = np.asarray(mean_anomaly, dtype=float)
    e = np.broadcast_to(np.asarray(eccentricity, dtype=float), mean_anomaly.shape)
    with np.errstate(under='ignore'):  # tiny M: E^2 and E^3 may underflow, harmlessly
        e_anomaly, _, _, k = _solve(mean_anomaly, e)
    return (e_anomaly + k * _k.TWO_PI_HI) + k * _k.TWO_PI_LO


def _e_minus_sin(e_anomaly, sin_e):
    """Return ``E - sin E`` for ``E >= 0``, the series below 1 (as the kernel's)."""
    x = e_anomaly * e_anomaly
    total = np.zeros_like(e_anomaly)
    for coefficient in _k.E_MINUS_SIN_SERIES[::-1]:
        total = total * x + coefficient
    return np.where(e_anomaly >= 1.0, e_anomaly - sin_e, total * x * e_anomaly)


def _solve(mean_anomaly, e):
    """
    Return ``E`` in ``[-pi, pi]``, ``sin(E/2)``, ``cos(E/2)`` and the revolutions ``k``.

    The kernel's reduction, start and Newton iteration, element by element (an element stops
    when the kernel would).
    """
    shape = mean_anomaly.shape
    mean_anomaly = mean_anomaly.reshape(-1)
    e = e.reshape(-1)
    k = np.floor(mean_anomaly / (_k.TWO_PI_HI + _k.TWO_PI_LO) + 0.5)
    reduced = (mean_anomaly - k * _k.TWO_PI_HI) - k * _k.TWO_PI_LO
    m = np.abs(reduced)
    e_anomaly = np.minimum(m + e, math.pi)
    high = e > 0.5
    if high.any():
        a = e[high] * _k.CUBIC_BOUND / 6.0
        p = (1.0 - e[high]) / (3.0 * a)
        q = m[high] / (2.0 * a)
        w2 = (q + np.sqrt(q * q + p * p * p)) ** (2.0 / 3.0)
        positive = w2 > 0.0
        safe = np.where(positive, w2, 1.0)
        cubic = np.where(positive, 2.0 * q / (safe + p + p * p / safe), np.inf)
        e_anomaly[high] = np.minimum(e_anomaly[high], cubic)
    sh, ch = np.sin(0.5 * e_anomaly), np.cos(0.5 * e_anomaly)
    active = np.ones(m.shape, dtype=bool)
    for _ in range(_k.KEPLER_ITERATIONS):
        index = np.flatnonzero(active)
        if index.size == 0:
            break
        value, ecc = e_anomaly.flat[index], e.flat[index]
        s, c = sh.flat[index], ch.flat[index]
        sin_e = 2.0 * s * c
        slope = (1.0 - ecc) + 2.0 * ecc * s * s
        step = ((_e_minus_sin(value, sin_e) + (1.0 - ecc) * sin_e) - m.flat[index]) / slope
        value = value - step
        e_anomaly.flat[index] = value
        done = step * step * np.maximum(1.0, ecc * np.abs(sin_e) / (2.0 * slope)) \
            <= _k.KEPLER_TOLERANCE * value
        sh.flat[index] = np.where(done, s - 0.5 * step * c, np.sin(0.5 * value))
        ch.flat[index] = np.where(done, c + 0.5 * step * s, np.cos(0.5 * value))
        active.flat[index] = ~done
    sign = np.where(reduced < 0.0, -1.0, 1.0)
    return tuple(value.reshape(shape) for value in (sign * e_anomaly, sign * sh, ch, k))


def perifocal_axes(raan, argument_of_perigee, inclination):
    """
    Return the perifocal axes ``P`` (to perigee) and ``Q`` in the inertial frame, ``(..., 3)``.

    The first two columns of ``R3(-RAAN) R1(-i) R3(-omega)`` (Vallado 2013, algorithm 10).
    """
    cos_node, sin_node = np.cos(raan), np.sin(raan)
    cos_perigee, sin_perigee = np.cos(argument_of_perigee), np.sin(argument_of_perigee)
    cos_i, sin_i = math.cos(inclination), math.sin(inclination)
    p = np.stack(np.broadcast_arrays(
        cos_node * cos_perigee - sin_node * sin_perigee * cos_i,
        sin_node * cos_perigee + cos_node * sin_perigee * cos_i,
        sin_perigee * sin_i,
    ), axis=-1)
    q = np.stack(np.broadcast_arrays(
        -cos_node * sin_perigee - sin_node * cos_perigee * cos_i,
        -sin_node * sin_perigee + cos_node * cos_perigee * cos_i,
        cos_perigee * sin_i,
    ), axis=-1)
    return p, q


class KeplerOrbit:
    """
    An orbit from Keplerian elements at a UTC ``epoch``: two-body motion, optionally J2's drift.

    ``semi_major_axis`` (m, above the Earth's equatorial radius), ``eccentricity`` (``0 <= e <
    1``, perigee above the surface), ``inclination``, ``raan``, ``argument_of_perigee``,
    ``mean_anomaly`` (rad, at the epoch), ``epoch`` (UTC: :func:`.epochs.utc_seconds`'s forms or
    seconds since J2000.0), ``j2``: drift the node, perigee and mean anomaly at J2's secular
    rates. A bad element raises :class:`~..checks.schema.FieldError` naming ``path.field``.
    """

    def __init__(
        self,
        semi_major_axis,
        eccentricity=0.0,
        inclination=0.0,
        raan=0.0,
        argument_of_perigee=0.0,
        mean_anomaly=0.0,
        epoch=0.0,
        j2: bool = False,
        gm: float = GM,
        path: str = 'orbit',
    ):
        checked = fields(
            {
                'semi_major_axis': semi_major_axis,
                'eccentricity': eccentricity,
                'inclination': inclination,
                'raan': raan,
                'argument_of_perigee': argument_of_perigee,
                'mean_anomaly': mean_anomaly,
                'j2': j2,
            },
            path,
            {key: param for key, param in ELEMENTS.items() if key != 'epoch'},
        )
        a, e = checked['semi_major_axis'], checked['eccentricity']
        if e >= 1.0:
            raise FieldError(
                f'{path}.eccentricity',
                f'must be < 1 (an ellipse; no parabolas or hyperbolas here), got {e!r}',
            )
        if a <= EQUATORIAL_RADIUS:
            raise FieldError(
                f'{path}.semi_major_axis',
                f"must be above the Earth's equatorial radius {EQUATORIAL_RADIUS:.0f} m, got "
                f'{a!r}',
            )
        perigee = a * (1.0 - e)
        if perigee <= EQUATORIAL_RADIUS:
            raise FieldError(
                f'{path}.eccentricity',
                f'the perigee radius a (1 - e) = {perigee:.6g} m is inside the Earth '
                f'(equatorial radius {EQUATORIAL_RADIUS:.0f} m); lower it or raise '
                'semi_major_axis',
            )
        if isinstance(epoch, (int, float)) and not isinstance(epoch, bool):
            if not math.isfinite(epoch):
                raise FieldError(f'{path}.epoch', f'expected a finite instant, got {shown(epoch)}')
            self.epoch = float(epoch)
        else:
            self.epoch = epochs.utc_seconds(epoch, f'{path}.epoch')
        self.semi_major_axis = a
        self.eccentricity = e
        self.inclination = checked['inclination']
        self.raan = checked['raan']
        self.argument_of_perigee = checked['argument_of_perigee']
        self.mean_anomaly = checked['mean_anomaly']
        self.j2 = checked['j2']
        self.gm = float(gm)
        #: two-body mean motion, rad/s
        self.keplerian_mean_motion = math.sqrt(self.gm / a**3)
        n = self.keplerian_mean_motion
        self.raan_rate = self.perigee_rate = 0.0
        self.mean_motion = n
        if self.j2:
            p = a * (1.0 - e) * (1.0 + e)
            factor = n * J2 * (EQUATORIAL_RADIUS / p) ** 2
            sin2 = math.sin(self.inclination) ** 2
            self.raan_rate = -1.5 * factor * math.cos(self.inclination)
            self.perigee_rate = 0.75 * factor * (4.0 - 5.0 * sin2)
            self.mean_motion = n + 0.75 * factor * math.sqrt((1.0 - e) * (1.0 + e)) * (
                2.0 - 3.0 * sin2
            )

        #: the perifocal axes at the epoch (constant without J2)
        self._axes = perifocal_axes(self.raan, self.argument_of_perigee, self.inclination)

    @classmethod
    def from_mapping(cls, mapping, path: str = 'orbit') -> KeplerOrbit:
        """Build the orbit of a scene's ``orbit:`` mapping (:data:`ELEMENTS`)."""
        checked = fields(mapping, path, ELEMENTS)
        return cls(**checked, path=path)

    @property
    def period(self) -> float:
        """Return the anomalistic period, s (``2 pi`` over the mean motion)."""
        return 2.0 * math.pi / self.mean_motion

    def kernel_row(self) -> np.ndarray:
        """Return the orbit's constants as :func:`.environment_kernels.kepler_state` reads them."""
        row = np.empty(_k.ORBIT_WIDTH)
        row[_k.A] = self.semi_major_axis
        row[_k.ECC] = self.eccentricity
        row[_k.MEAN_MOTION] = self.mean_motion
        row[_k.MEAN_ANOMALY] = self.mean_anomaly
        row[_k.RAAN] = self.raan
        row[_k.RAAN_RATE] = self.raan_rate
        row[_k.ARGP] = self.argument_of_perigee
        row[_k.ARGP_RATE] = self.perigee_rate
        row[_k.COS_I] = math.cos(self.inclination)
        row[_k.SIN_I] = math.sin(self.inclination)
        row[_k.GM] = self.gm
        row[_k.PX:_k.PZ + 1], row[_k.QX:_k.QZ + 1] = self._axes
        return row

    def state(self, t):
        """
        Return the inertial position (m) and velocity (m/s) at ``t`` s after the epoch.

        ``t``: a number or an array (any order); the results have shape ``t.shape + (3,)``.
        """
        t = np.asarray(t, dtype=float)
        a, e = self.semi_major_axis, self.eccentricity
        mean_anomaly = self.mean_anomaly + self.mean_motion * t
        with np.errstate(under='ignore'):  # near perigee E^3 may underflow, harmlessly
            _, sh, ch, _ = _solve(mean_anomaly, np.full(mean_anomaly.shape, e))
        sin_e = 2.0 * sh * ch
        one_minus_cos = 2.0 * sh * sh
        beta = math.sqrt((1.0 - e) * (1.0 + e))
        radius = a * ((1.0 - e) + e * one_minus_cos)
        x = a * ((1.0 - e) - one_minus_cos)
        y = a * beta * sin_e
        speed = math.sqrt(self.gm * a) / radius
        vx = -speed * sin_e
        vy = speed * beta * (1.0 - one_minus_cos)
        if self.raan_rate == 0.0 and self.perigee_rate == 0.0:
            p, q = self._axes
        else:
            p, q = perifocal_axes(
                self.raan + self.raan_rate * t,
                self.argument_of_perigee + self.perigee_rate * t,
                self.inclination,
            )
        position = x[..., None] * p + y[..., None] * q
        velocity = vx[..., None] * p + vy[..., None] * q
        return position, velocity

    def position(self, t) -> np.ndarray:
        """Return :meth:`state`'s first half: where the body is, m, ``t`` s after the epoch."""
        return self.state(t)[0]
