"""Test kit: the simulator node in process, stepped by your test, with the exact truth beside it.

    from torquefree_ros.testing import simulator

    with simulator(scene="estimator") as sim:
        estimator = MyEstimator(context=sim.context, namespace=sim.namespace)
        sim.add_node(estimator)
        sim.advance(100)            # 100 samples out, each processed by every node added
        truth = sim.truth(sim.t)    # the exact state at the last sample's time

The pytest plugin (``torquefree_ros.testing.pytest_plugin``, registered as a ``pytest11`` entry point)
gives the same as the ``torquefree_sim`` fixture. The contract: docs/CONTRACT.md, "Test kit".
"""

from .kit import DEFAULT_TIMEOUT, Sample, Simulator, SimulatorTimeout, State, Tap, message_stamp_ns, simulator, stamp_ns

__all__ = ["DEFAULT_TIMEOUT", "Sample", "Simulator", "SimulatorTimeout", "State", "Tap", "message_stamp_ns",
           "simulator", "stamp_ns"]
