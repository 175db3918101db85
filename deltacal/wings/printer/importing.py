"""A printer as it is found: its firmware's configuration into deltacal's files, or a log's probe results.

``deltacal import printer.cfg -o DIR`` (or RepRapFirmware's ``config.g``) writes ``DIR/printer.toml``
and, from Klipper's SAVE_CONFIG block's ``[delta_calibrate]``, ``DIR/probe.csv`` and
``DIR/distances.csv``; ``deltacal import LOG [--config CONFIG] -o probe.csv`` writes the log's probe
results (the configuration gives the probe's offsets: Klipper's lines from 2026 need them). The
kind of input is told by its content (:func:`~deltacal.printer.firmware.input_firmware`), or
``--firmware`` names it; a file none recognises is refused in one line asking for ``--firmware``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...exceptions import InputError
from ...io.paths import check_input, check_output, check_output_folder
from ...printer.files.importer import OUTPUT_FILES
from ...printer.files.measurements import write_probe_heights
from ...printer.firmware import input_firmware
from ...printer.firmware.base import Firmware
from ..base import Done
from ..requests import ImportRequest


def import_found(request: ImportRequest) -> Done:
    """``deltacal import``: the robot file (and saved measurements) of a configuration, or a log's heights."""
    check_input(request.input)
    try:
        text = Path(request.input).read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read the file ({exc.strerror})", str(request.input)) from None
    firmware, is_log = input_firmware(request.input, text, request.firmware)
    if is_log:
        return _import_log(request, text, firmware)
    request.check_config(firmware.title)
    folder = Path(request.output)
    check_output_folder(folder, OUTPUT_FILES, [request.input], f"import of {firmware.title}'s configuration")
    made = not folder.exists()
    if made:
        folder.mkdir()
    try:
        imported = firmware.import_config(request.input, folder, request.effector_radius, request.rod_spacing,
                                          request.nozzle_drop)
    except BaseException:
        if made and not any(folder.iterdir()):
            folder.rmdir()  # nothing written: no folder left behind either
        raise
    return Done(tuple(imported.said))


def _import_log(request: ImportRequest, text: str, firmware: Firmware[Any]) -> Done:
    """A log's probe results into a probe heights file."""
    request.check_log()
    if request.config is not None:
        check_input(request.config)
    check_output(request.output, [request.input] + ([request.config] if request.config else []))
    log = firmware.read_probe_log(request.input, request.config, text)
    write_probe_heights(request.output, log.commanded[:, :2], log.commanded[:, 2], log.trigger_height)
    trigger = ""
    if log.trigger_height is not None:
        trigger = f", trigger height {log.trigger_height[0]:g} mm ({log.trigger_source})"
    return Done((f"wrote {request.output}: {len(log.commanded)} probe results of {firmware.title} (lines "
                 f"{log.lines[0]}..{log.lines[-1]} of {request.input}){trigger}",))
