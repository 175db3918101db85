"""The printed calibration object of a printer and its sheet.

Its features and mesh (:mod:`.object`), the balls' labels and their lettering (:mod:`.labels`,
:mod:`.lettering`), which of its distances to measure (:mod:`.plan`, ``plan --object``) and the
measuring sheet (:mod:`.sheet`).
"""
