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
A TLE through SGP4 against Vallado's verification cases, shipped inside the ``sgp4`` package.

``sgp4/SGP4-VER.TLE`` holds the test element sets (each line 2 followed by the start, stop and
step in minutes) and ``sgp4/tcppver.out`` the TEME states Vallado's C++ gives at those times (km,
km/s, printed to 1e-8 and 1e-9). The package's own test allows 2e-7 in each; so does this one. The
same file's damaged sets (33333-33335, "checksum error as expected") must be refused.
"""

from __future__ import annotations

from importlib import resources
import math

import numpy as np
import pytest
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.environment import earth, epochs
from torquefree_ros.core.environment.tle import check_lines, checksum, TLEOrbit

pytest.importorskip('sgp4')

# the package's tolerance in tcppver.out's units (km, km/s)
VERIFICATION_TOLERANCE = 2e-7


def _verification_sets():
    text = (resources.files('sgp4') / 'SGP4-VER.TLE').read_text().splitlines()
    lines = [line for line in text if line[:2] in ('1 ', '2 ')]
    return {line1[2:7].lstrip('0'): (line1[:69], line2[:69], line2[69:].split())
            for line1, line2 in zip(lines[::2], lines[1::2])}


def _expected_states():
    states, current = {}, None
    for line in (resources.files('sgp4') / 'tcppver.out').read_text().splitlines():
        fields = line.split()
        if len(fields) == 2 and fields[1] == 'xx':
            current = states.setdefault(fields[0], [])
        elif fields and current is not None:
            current.append([float(value) for value in fields[:7]])
    return {number: np.array(rows) for number, rows in states.items()}


SETS = _verification_sets()
EXPECTED = _expected_states()


@pytest.mark.parametrize('number', [
    '5',  # the TEME example (near Earth, e = 0.19)
    '6251',  # near Earth, perigee 377 km: the drag equations
    '8195',  # Molniya: 12 h resonant, deep space
    '9998',  # deep space, propagated backwards
    '28057',  # near-circular LEO
    '23599',  # deep space, 6 h resonant
])
def test_sgp4_reproduces_vallados_verification_states(number):
    line1, line2, _ = SETS[number]
    orbit = TLEOrbit(line1, line2)
    expected = EXPECTED[number]
    position, velocity = orbit.teme_state(expected[:, 0] * 60.0)
    assert np.abs(position / 1e3 - expected[:, 1:4]).max() <= VERIFICATION_TOLERANCE
    assert np.abs(velocity / 1e3 - expected[:, 4:7]).max() <= VERIFICATION_TOLERANCE
    # the inertial state is the TEME state turned by TEME -> EME2000 at each instant
    inertial_position, inertial_velocity = orbit.state(expected[:, 0] * 60.0)
    matrix = earth.teme_matrix(orbit.epoch + expected[:, 0] * 60.0)
    assert np.allclose(inertial_position, np.einsum('nij,nj->ni', matrix, position),
                       rtol=0.0, atol=1e-6)
    assert np.allclose(np.linalg.norm(inertial_velocity, axis=1),
                       np.linalg.norm(velocity, axis=1), rtol=1e-14, atol=0.0)


def test_the_tle_epoch_is_a_utc_instant():
    orbit = TLEOrbit(*SETS['5'][:2])
    # 00179.78495062: 2000-06-27 18:50:19.7336 UTC (the sgp4 package's own test: .733568)
    assert abs(epochs.utc_datetime(orbit.epoch).timestamp()
               - epochs.utc_seconds('2000-06-27T18:50:19.733568Z')
               - epochs.J2000.timestamp()) <= 1e-3


def test_a_decayed_satellite_fails_with_sgp4s_reason():
    orbit = TLEOrbit(*SETS['28872'][:2])  # decays ~55 min after its epoch (tcppver.out stops)
    orbit.teme_state(np.arange(0.0, 50.0, 5.0) * 60.0)
    with pytest.raises(ValueError, match=r'orbit\.tle: SGP4 fails 3300\.0 s after the epoch: '
                                         r'SGP4 error 6: .*decayed'):
        orbit.teme_state(np.arange(0.0, 60.0, 5.0) * 60.0)


def _with_checksum(line: str) -> str:
    return line[:68] + str(checksum(line))


@pytest.mark.parametrize('number', ['33333', '33334', '33335'])
def test_the_verification_files_damaged_sets_are_refused(number):
    with pytest.raises(FieldError, match=r'orbit\.tle\.line\d: checksum'):
        TLEOrbit(*SETS[number][:2])


def test_bad_lines_are_refused_naming_the_line_and_the_field():
    line1, line2, _ = SETS['5']
    cases = [
        ((line1[:68], line2), 'orbit.tle.line1', '69 columns, this one 68'),
        ((line2, line2), 'orbit.tle.line1', "must start with '1 '"),
        ((line1, line2[:68] + 'x'), 'orbit.tle.line2', 'column 69 is the checksum digit'),
        ((line1, line2[:68] + str((int(line2[68]) + 1) % 10)), 'orbit.tle.line2', 'checksum'),
        ((line1, _with_checksum(line2[:2] + '00006' + line2[7:])), 'orbit.tle.line2',
         'catalogue number'),
        ((line1, _with_checksum(line2[:8] + ' 34.2x82' + line2[16:])), 'orbit.tle.line2',
         'inclination (columns 9-16): expected a number'),
        ((line1, _with_checksum(line2[:8] + '194.2682' + line2[16:])), 'orbit.tle.line2',
         'inclination 194.2682 is outside [0, 180]'),
        ((line1, _with_checksum(line2[:26] + '18596-7' + line2[33:])), 'orbit.tle.line2',
         'eccentricity (columns 27-33)'),
        ((line1, _with_checksum(line2[:52] + ' -.8241915' + line2[62:])), 'orbit.tle.line2',
         'mean motion'),
        ((_with_checksum(line1[:20] + 'day.78495062' + line1[32:]), line2), 'orbit.tle.line1',
         'epoch day of the year'),
        ((None, line2), 'orbit.tle.line1', 'expected the TLE line as a string'),
    ]
    for lines, path, words in cases:
        with pytest.raises(FieldError) as raised:
            TLEOrbit(*lines)
        assert raised.value.path == path, lines
        assert words in str(raised.value), str(raised.value)
    # trailing whitespace is not a fault; the lines come back as SGP4 reads them
    assert check_lines(line1 + '\r\n', line2 + '  ') == (line1, line2)
    assert math.isfinite(TLEOrbit(line1 + '\n', line2).epoch)
