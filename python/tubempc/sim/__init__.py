"""Closed-loop simulation (room 6 of docs/layout.md): the plant and the loop around the C++ controller.

- :mod:`.closed_loop`: :func:`~.closed_loop.simulate`, one run of a scenario (truth propagation,
  disturbances, navigation, actuators, controller) into a :class:`~tubempc.results.records.RunRecord`.
- :mod:`.plant`: the project's plant (``simulation.plant = "project"``).
- :mod:`.basilisk`: Basilisk's plant (``simulation.plant = "basilisk"``, the optional extra ``basilisk``).
"""
