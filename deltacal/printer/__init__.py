"""The linear Delta printer's wing: what a printer has that a rotary Delta does not.

It leans on the shared engine (geometry, kinematics, identification, compensation) and adds:

* :mod:`.robot`: :class:`~.robot.NominalLinearDelta`, a printer's nominal values, and the bed's
  gauge (the shift and turn along the bed that no probe or caliper sees).
* :mod:`.robot_file`: a printer's robot file (``kind = "linear"``) read into those values
  (:func:`deltacal.robots.load_robot` reads a robot file of either kind).
* :mod:`.errormodels`: the printer's complete error model and its firmware's values as moves of the
  full geometry.
* :mod:`.identification` and :mod:`.evidence`: probe heights and caliper distances identified with
  the build tolerances as priors, and the tolerances' scale from the measurements' evidence.
* :mod:`.object` and :mod:`.plan`: the printed calibration object, its distances and the probe grid.
* :mod:`.measurement_files`: the probe heights and printed distances files.
* :mod:`.simulation`, :mod:`.comparison`, :mod:`.demo`: simulated printers measured through their
  firmware, deltacal's whole path beside the firmware's own calibration, the printer demo.
* :mod:`.firmware`: the firmwares that run a printer, one subpackage each behind one interface
  (:class:`~.firmware.base.Firmware`).
"""
