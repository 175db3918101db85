"""A printer's files: its robot file, its measurement files, a firmware configuration imported.

The robot file (:mod:`.robot_file`), probe heights and printed distances (:mod:`.measurements`),
``deltacal import``'s writer shared by the firmwares (:mod:`.importer`) and whether two files are
of one printer (:mod:`.same_printer`).
"""
