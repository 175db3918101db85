"""The firmwares that run a linear Delta printer, one subpackage each.

A firmware holds its own (classical) model of the printer: vertical towers, one rod length per
tower, a point effector. Each firmware's subpackage has the same parts:

* ``config``: its configuration file read and written (values in the firmware's own words);
* ``model``: its kinematic model (commanded position to steps and back) and its limits, and the
  firmware as a controller of the printer's readings;
* ``fit``: the values that fit an identified printer best over the printable volume;
* ``calibrate``: its own calibration, emulated from its algorithm, for the comparison.

Klipper (:mod:`.klipper`) is the first.
"""
