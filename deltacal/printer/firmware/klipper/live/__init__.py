"""Klipper correcting every move itself: the live module and the data it needs (``export --live``)."""
