"""Klipper: its ``printer.cfg`` (:mod:`.config`), delta model and limits (:mod:`.model`), the values
fitted to an identified printer (:mod:`.fit`) and its own ``DELTA_CALIBRATE`` (:mod:`.calibrate`).
"""
