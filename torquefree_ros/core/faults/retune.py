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
A sensor output's noise parameters changed while a run goes on.

``{TOPIC: {PARAMETER: value}}`` names sensor outputs by topic and the noise parameters to change
(:data:`NOISE_PARAMETERS`, in the scene's units); the output is rebuilt with them and checked as
the scene checks it (every error names its path). Its rows from a given sample on are those of the
rebuilt sensor at that sample: the sensor's draws are keyed by the sample index and the seed,
which stays, so the same normals are scaled by the new values (a white noise changes from that
sample on; a random walk's or a Gauss-Markov bias's state is the rebuilt sensor's, as if it had
had the new values from the start).
"""

from __future__ import annotations

import numpy as np

from .schedule import FAULTED_OUTPUTS
from ..checks.schema import check_keys, child, FieldError, fields, shown

#: output name -> the parameters a run may change (those its sensor has)
NOISE_PARAMETERS = {
    'imu': (
        'angle_random_walk',
        'gyro_noise_density',
        'rate_random_walk',
        'gyro_bias_random_walk',
        'bias_instability',
        'bias_correlation_time',
    ),
    'star_tracker': ('cross_boresight_noise', 'about_boresight_noise'),
    'magnetometer': ('noise',),
    'sun_sensor': ('noise',),
}


def parse_noise_changes(data, path: str, outputs) -> dict:
    """
    Check ``{TOPIC: {PARAMETER: value}}`` against the run's ``outputs``.

    Return ``{topic: the rebuilt output}``; errors are ``FieldError`` naming their path.
    """
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise FieldError(path, f'expected a mapping of output topics, got {shown(data)}')
    by_topic = {output.topic: output for output in outputs}
    sensors = [topic for topic, o in by_topic.items() if o.name in NOISE_PARAMETERS]
    rebuilt = {}
    for topic, changes in data.items():
        where = child(path, topic)
        output = by_topic.get(topic)
        if output is None or output.name not in FAULTED_OUTPUTS:
            raise FieldError(
                where,
                f'not the topic of a sensor output of the scene (sensors: '
                f'{", ".join(sensors) or "none"})',
            )
        allowed = [key for key in NOISE_PARAMETERS[output.name] if key in output.parameters]
        if not isinstance(changes, dict):
            raise FieldError(where, f'expected a mapping (keys: {", ".join(allowed)})')
        check_keys(changes, allowed, where)
        rebuilt[topic] = retuned(output, changes, where)
    return rebuilt


def retuned(output, changes: dict, path: str):
    """Return ``output`` rebuilt with ``changes`` to its parameters, checked as a scene's."""
    values = {
        key: value.tolist() if isinstance(value, np.ndarray) else value
        for key, value in output.values.items()
        if value is not None
    }
    values.update(changes)
    new = type(output).from_parameters(fields(values, path, type(output).parameters), path)
    if output.place is not None:
        new = new.placed(output.place, path)
    return new


__all__ = ['NOISE_PARAMETERS', 'parse_noise_changes', 'retuned']
