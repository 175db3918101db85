"""Klipper correcting every move itself: the live module and the data it needs (``export --live``).

* :mod:`.field`: the correction of Klipper's commands (the offline route's exact corrected targets)
  sampled on a regular grid over Klipper's printable volume, its interpolation and its sampling error.
* :mod:`.export`: ``deltacal_geometry.py`` and its ``[deltacal_geometry]`` section written together.
* :mod:`.deltacal_geometry`: the module itself, standard-library Python that runs inside Klipper
  (a move transform, as ``bed_mesh`` and ``skew_correction`` are), shipped as it is.
"""
