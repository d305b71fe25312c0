"""Simulators: rides of a self-balancing transporter with a tablet on the handlebar.

:func:`simulate_scenario` is the entry point (``spotfree simulate``); the modules hold the rider's programmes
(:mod:`~spotfree.sim.manoeuvres`), the vehicle and rider dynamics (:mod:`~spotfree.sim.vehicle`), the sensor model
(:mod:`~spotfree.sim.imu`), the GPS (:mod:`~spotfree.sim.gps`) and the scenarios (:mod:`~spotfree.sim.scenarios`).
"""

from spotfree.sim.scenarios import SCENARIOS, simulate_ride, simulate_scenario

__all__ = ["SCENARIOS", "simulate_ride", "simulate_scenario"]
