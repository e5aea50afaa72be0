"""Models (room 2 of docs/layout.md): the Python face of the C++ core's models, on numpy arrays.

- :mod:`.dynamics`: the 6-DOF proximity model (:class:`~.dynamics.ProximityModel`), its parameters and
  constraints;
- :mod:`.mpc`: the tube MPC and independent solvers of its QP (cross-checks and benchmarks);
- :mod:`.disturbances`: the additive disturbance sets and the actuator mismatch of the plant.
"""
