"""The work-precision report (``torquefree_bench``): what each propagator's accuracy costs in time,
measured against the high-precision reference solutions of the hard cases, beside scipy's
``solve_ivp`` and (when importable) MuJoCo's RK4 free body, with the cost of the effects and of the
ROS layer per sample. A measuring tool, not part of the simulator: the node never imports it."""
