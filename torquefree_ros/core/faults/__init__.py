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
Faults of the sensor outputs and actuators, and run-time changes of the sensors' noise.

- :mod:`.schedule`: the fault kinds (stuck, bias, noise, spikes, dropout; the actuators'),
  checked field by field against a scene's outputs, and the columns each acts on per output;
- :mod:`.injector`: a run's faults applied to its outputs' rows after the sensors computed them,
  on each output's own sample grid, with seeded draws;
- :mod:`.batch`: the faults of many runs (a plant batch's bodies) applied to one sample's rows of
  every run at once, bit for bit each run's injector;
- :mod:`.draws`: the faults' seeded draws (counter-based ``Philox``), one fault's block of samples
  or one sample of many faults;
- :mod:`.actuators`: a run's actuator faults (a wheel that stops responding or errs in its
  motor torque, stuck magnetorquers, a stuck or erring commanded torque, a noise on any of them)
  applied to the inputs its command holds keep;
- :mod:`.retune`: a sensor output rebuilt with new noise parameters while a run goes on.

Beside :mod:`..propagators`, under :mod:`..scene` and :mod:`..run`. May import: :mod:`..effects`
and every room below it.
"""

from .actuators import ActuatorFaults, check_actuator_faults
from .injector import FaultInjector
from .retune import NOISE_PARAMETERS, parse_noise_changes, retuned
from .schedule import (
    ACTUATOR_FAULTS,
    describe_fault,
    Fault,
    FAULT_KINDS,
    FAULTED_OUTPUTS,
    parse_faults,
)

__all__ = [
    'ACTUATOR_FAULTS',
    'ActuatorFaults',
    'FAULTED_OUTPUTS',
    'FAULT_KINDS',
    'NOISE_PARAMETERS',
    'Fault',
    'FaultInjector',
    'check_actuator_faults',
    'describe_fault',
    'parse_faults',
    'parse_noise_changes',
    'retuned',
]
