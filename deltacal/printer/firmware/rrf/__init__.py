"""RepRapFirmware 3.x, a printer firmware behind :class:`~..base.Firmware`.

Its ``config.g`` / ``config-override.g`` (:mod:`.config`) and where they keep the values
(:mod:`.apply`), its linear delta model and limits (:mod:`.model`), the values fitted to an
identified printer (:mod:`.fit`), its probe program (:mod:`.probing`) and the
:class:`~.firmware.RRF` that delegates to them (:mod:`.firmware`). The reference is RRF's own
source, ``src/Movement/Kinematics/LinearDeltaKinematics.cpp``.
"""
