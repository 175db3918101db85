"""Marlin 2.x, the firmware of many Delta printers (``#define DELTA``).

Its settings as ``M503`` reports them (:mod:`.settings`), its delta model, limits and controller
(:mod:`.model`), its values of a given model written by its own rules (:mod:`.values`), the values
fitted to an identified printer (:mod:`.fit`), and Marlin behind the firmware interface
(:mod:`.firmware`: :data:`~.firmware.MARLIN`).
"""
