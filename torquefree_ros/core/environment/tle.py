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
An orbit from a two-line element set, propagated by SGP4.

SGP4/SDP4 is the ``sgp4`` package's (Brandon Rhodes' wrapper of Vallado's C++ of "Revisiting
Spacetrack Report #3", Vallado et al. 2006, AIAA 2006-6753), with the WGS 72 constants TLEs are
fitted with and its improved operation mode ('i'). Its output is in TEME (true equator, mean
equinox of date); :func:`.earth.teme_matrix` rotates it into the inertial frame, EME2000
(precession IAU 1976, nutation IAU 1980 to 0.01 arcsec, the equation of the equinoxes; the frame
is the GCRF to 0.03 arcsec, :mod:`.earth`). SGP4's own error against the real orbit is of the
order of a kilometre at the TLE's epoch, growing by one to a few kilometres a day: the rotation's
errors (0.05 arcsec against astropy's GCRS, 2 m at 7000 km) are far below it.

The lines are checked before SGP4 reads them (it does not check): 69 columns, the line numbers,
the checksums (modulo 10 of the digits, a '-' counting 1), the same catalogue number on both, and
every orbital field a number in its range; each error names the line and the field.
"""

from __future__ import annotations

import math

import numpy as np

from . import earth, epochs
from ..checks.schema import FieldError, shown

# the orbital fields of line 2 (columns, 0-based slices): name, slice, minimum, maximum
_LINE2_FIELDS = (
    ('inclination', slice(8, 16), 0.0, 180.0),
    ('right ascension of the ascending node', slice(17, 25), 0.0, 360.0),
    ('argument of perigee', slice(34, 42), 0.0, 360.0),
    ('mean anomaly', slice(43, 51), 0.0, 360.0),
    ('mean motion', slice(52, 63), 0.0, 20.0),
)


def checksum(line: str) -> int:
    """Return the TLE checksum of a line's first 68 columns: digits summed, '-' as 1, modulo 10."""
    return sum(int(c) if c.isdigit() else c == '-' for c in line[:68]) % 10


def check_lines(line1, line2, path: str = 'orbit.tle') -> tuple[str, str]:
    """
    Return the two lines of a TLE, checked; a fault raises ``FieldError`` naming line and field.

    Trailing whitespace (a newline, a carriage return) is dropped; anything else must be the
    standard 69 columns.
    """
    lines = []
    for number, line in ((1, line1), (2, line2)):
        where = f'{path}.line{number}'
        if not isinstance(line, str):
            raise FieldError(where, f'expected the TLE line as a string, got {shown(line)}')
        line = line.rstrip()
        if len(line) != 69:
            raise FieldError(where, f'a TLE line has 69 columns, this one {len(line)}')
        if not line.isascii():
            raise FieldError(where, 'a TLE line is ASCII')
        if line[0] != str(number) or line[1] != ' ':
            raise FieldError(where, f"must start with '{number} ' (the line number), got "
                             f'{line[:2]!r}')
        if not line[68].isdigit():
            raise FieldError(where, f'column 69 is the checksum digit, got {line[68]!r}')
        if int(line[68]) != checksum(line):
            raise FieldError(
                where,
                f'checksum: column 69 says {line[68]} but the line sums to {checksum(line)} '
                '(mod 10): a damaged or edited line',
            )
        lines.append(line)
    line1, line2 = lines
    if line1[2:7] != line2[2:7]:
        raise FieldError(
            f'{path}.line2',
            f"catalogue number {line2[2:7]!r} differs from line 1's {line1[2:7]!r}: two "
            'different element sets',
        )
    _number(line1, slice(18, 20), 'epoch year', f'{path}.line1', 0.0, 99.0)
    _number(line1, slice(20, 32), 'epoch day of the year', f'{path}.line1', 1.0, 367.0)
    for name, columns, low, high in _LINE2_FIELDS:
        _number(line2, columns, name, f'{path}.line2', low, high)
    _number('0.' + line2[26:33], slice(None), 'eccentricity', f'{path}.line2', 0.0, 1.0)
    return line1, line2


def _number(line, columns, name, where, low, high):
    text = line[columns]
    try:
        value = float(text)
    except ValueError:
        raise FieldError(where, f'{name} (columns {_columns(columns)}): expected a number, got '
                         f'{text!r}') from None
    if not (math.isfinite(value) and low <= value <= high):
        raise FieldError(where, f'{name} {value!r} is outside [{low:g}, {high:g}]')
    return value


def _columns(columns: slice) -> str:
    return f'{columns.start + 1}-{columns.stop}' if columns.start is not None else '27-33'


class TLEOrbit:
    """
    An orbit from a two-line element set: SGP4's TEME states rotated into the inertial frame.

    ``line1``, ``line2``: the TLE (checked by :func:`check_lines`); ``path`` names the scene
    field in errors. ``epoch``: the TLE's epoch as a UTC instant (:mod:`.epochs`); :meth:`state`
    takes seconds since it.
    """

    def __init__(self, line1, line2, path: str = 'orbit.tle'):
        from sgp4.api import Satrec, WGS72

        self.line1, self.line2 = check_lines(line1, line2, path)
        self.path = path
        self.satrec = Satrec.twoline2rv(self.line1, self.line2, WGS72)
        if self.satrec.error:
            raise FieldError(path, f'SGP4 cannot start from these elements: {self._error()}')
        #: the TLE's epoch, UTC seconds since J2000.0 (the TLE gives it to 1e-8 day)
        self.epoch = ((self.satrec.jdsatepoch - epochs.J2000_JD) + self.satrec.jdsatepochF) \
            * epochs.SECONDS_PER_DAY

    def __getstate__(self) -> dict:
        """Pickle the lines, not the SGP4 record (it does not pickle): a worker rebuilds it."""
        state = self.__dict__.copy()
        del state['satrec']
        return state

    def __setstate__(self, state: dict) -> None:
        from sgp4.api import Satrec, WGS72

        self.__dict__.update(state)
        self.satrec = Satrec.twoline2rv(self.line1, self.line2, WGS72)

    def _error(self, code=None) -> str:
        from sgp4.api import SGP4_ERRORS

        code = self.satrec.error if code is None else int(code)
        return f'SGP4 error {code}: {SGP4_ERRORS.get(code, "unknown")}'

    def teme_state(self, t):
        """
        Return SGP4's TEME position (m) and velocity (m/s) at ``t`` s after the TLE's epoch.

        A time SGP4 cannot propagate to (the satellite decayed, the elements diverged) raises
        ``ValueError`` with SGP4's reason and the time.
        """
        t = np.asarray(t, dtype=float)
        flat = t.reshape(-1)
        whole = np.full(flat.shape, self.satrec.jdsatepoch)
        fraction = self.satrec.jdsatepochF + flat / epochs.SECONDS_PER_DAY
        errors, position, velocity = self.satrec.sgp4_array(whole, fraction)
        if np.any(errors):
            first = int(np.flatnonzero(errors)[0])
            raise ValueError(
                f'{self.path}: SGP4 fails {float(flat[first])!r} s after the epoch: '
                f'{self._error(errors[first])}'
            )
        shape = t.shape + (3,)
        return position.reshape(shape) * 1e3, velocity.reshape(shape) * 1e3

    def state(self, t):
        """Return the EME2000 position (m) and velocity (m/s) ``t`` s after the epoch."""
        position, velocity = self.teme_state(t)
        matrix = earth.teme_matrix(self.epoch + np.asarray(t, dtype=float))
        rotate = '...ij,...j->...i'
        return np.einsum(rotate, matrix, position), np.einsum(rotate, matrix, velocity)

    def position(self, t) -> np.ndarray:
        """Return :meth:`state`'s first half: where the body is, m, ``t`` s after the epoch."""
        return self.state(t)[0]
