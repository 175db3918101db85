"""Klipper, the firmware of most Delta printers that deltacal meets.

Its ``printer.cfg`` (:mod:`.config`), its delta model and limits (:mod:`.model`), the values fitted to
an identified printer (:mod:`.fit`) and its own ``DELTA_CALIBRATE`` (:mod:`.calibrate`); what
``deltacal import`` reads: the measurements a configuration saved (:mod:`.saved`), the printer it
describes (:mod:`.importer`), probe results in a log (:mod:`.log`); Klipper behind the firmware
interface (:mod:`.firmware`: :data:`~.firmware.KLIPPER`).
"""
