"""The accuracy a propagator's settings deliver, as the reset summary and /diagnostics state it:
checked against independent references (the mpmath solution, a much tighter integration)."""

import numpy as np
import pytest

from torquefree_ros.bench.cases import load_cases
from torquefree_ros.core.accuracy import ESTIMATE_HORIZON, estimate_accuracy, trajectory_errors
from torquefree_ros.core.effects import parse_effect
from torquefree_ros.core.propagators import make_propagator
from torquefree_ros.core.simulation import Simulation

FLAT_PLATE = load_cases(["flat_plate"])[0]
DAMPER = (parse_effect({"damper": {"inertia": 0.1, "damping": 0.05}}, "effects[0]"),)


def test_the_exact_propagator_says_so():
    p = make_propagator(FLAT_PLATE.inertia, FLAT_PLATE.angular_velocity, FLAT_PLATE.orientation)
    assert estimate_accuracy(p).describe() == "exact (closed form: float64 rounding of the inputs)"


@pytest.mark.parametrize("name, options", [("rk4", {"step": 0.05}), ("lie_rk4", {"step": 0.05}),
                                           ("dop853", {"rtol": 1e-7, "atol": 1e-9})])
def test_torque_free_estimate_matches_the_error_against_the_mpmath_reference(name, options):
    case = FLAT_PLATE
    p = make_propagator(case.inertia, case.angular_velocity, case.orientation, name, **options)
    estimate = estimate_accuracy(p)
    assert estimate.horizon_s == ESTIMATE_HORIZON and estimate.reference == "the exact solution"
    within = case.times <= ESTIMATE_HORIZON  # on the estimate's grid (every 0.5 s)
    fresh = make_propagator(case.inertia, case.angular_velocity, case.orientation, name, **options)
    rate, attitude = trajectory_errors(*fresh(case.times[within]), case.omega[within], case.q[within])
    # the estimate's samples include the reference's: it is at least the error there, and the
    # error grows smoothly in between
    assert attitude.max() * (1 - 1e-6) <= estimate.attitude_rad <= 2.0 * attitude.max()
    assert rate.max() * (1 - 1e-6) <= estimate.rate_rel <= 2.0 * rate.max()
    assert f"attitude error ~{estimate.attitude_rad:.1e} rad" in estimate.describe()


@pytest.mark.parametrize("name, options, factor", [("rk4", {"step": 0.02}, 1.5), ("lie_rk4", {"step": 0.02}, 1.5),
                                                   ("dop853", {"rtol": 1e-7, "atol": 1e-9}, 3.0)])
def test_estimate_with_effects_matches_a_much_tighter_integration(name, options, factor):
    start = ([3.0, 2.0, 1.0], [0.3, 0.2, 1.0], [0.0, 0.0, 0.0, 1.0])
    p = make_propagator(*start, name, effects=DAMPER, **options)
    estimate = estimate_accuracy(p)
    horizon = min(ESTIMATE_HORIZON, 2000 * options.get("step", np.inf))
    assert estimate.horizon_s == horizon
    times = np.linspace(0.0, horizon, 21)
    reference = make_propagator(*start, "dop853", effects=DAMPER, rtol=1e-13, atol=1e-15)(times)
    rate, attitude = trajectory_errors(*make_propagator(*start, name, effects=DAMPER, **options)(times), *reference)
    assert attitude.max() / factor <= estimate.attitude_rad <= factor * attitude.max()
    assert rate.max() / factor <= estimate.rate_rel <= factor * rate.max()


def test_the_estimate_does_not_advance_the_running_propagator():
    p = make_propagator(FLAT_PLATE.inertia, FLAT_PLATE.angular_velocity, FLAT_PLATE.orientation, "rk4", step=0.01)
    before = p(np.array([0.5]))
    simulation = Simulation(p, 100.0)
    assert "accuracy: attitude error ~" in simulation.summary()
    assert simulation.accuracy in simulation.summary()
    np.testing.assert_array_equal(p(np.array([0.5]))[1], before[1])
