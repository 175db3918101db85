"""How to apply RepRapFirmware values: in the file and at the line where the configuration keeps them.

``M500`` writes ``M665`` and ``M666`` to ``config-override.g``, which only a ``config.g`` running
``M501`` after its own lines reads at start-up: a ``config.g`` that holds them and runs no ``M501``
must have its own lines replaced (issue 39, item 4).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from deltacal.printer.firmware.rrf.config import APPLY_NOTE, load_rrf
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

DATA = Path(__file__).resolve().parent / "data" / "rrf"


def _config(tmp_path: Path, edit=lambda text: text, override: bool = True) -> Path:
    """tests/data's config.g (M665 line 7, M666 line 8, M92 line 11, M501 line 18), edited."""
    (tmp_path / "config.g").write_text(edit((DATA / "config.g").read_text()))
    if override:
        shutil.copy(DATA / "config-override.g", tmp_path / "config-override.g")
    return tmp_path / "config.g"


def _written_note(config: Path) -> str:
    """The second line of the values exported for ``config``: how to apply them."""
    return RRF_FIRMWARE.config_text(load_rrf(config), config, title="t").splitlines()[1][2:]


def test_a_config_g_without_m501_has_its_own_lines_replaced(tmp_path):
    config = _config(tmp_path, lambda text: text.replace("M501 ", "; M501 "), override=False)
    note = RRF_FIRMWARE.apply_note_for(config)
    assert note == ("Replace the M665 line of config.g (line 7), the M666 line of config.g (line 8) and the "
                    "M92 line of config.g (line 11) with these: config.g runs no M501, so M500 "
                    "(config-override.g) would be lost at the next start-up.")
    assert _written_note(config) == note


def test_a_config_g_running_m501_has_config_override_g_lines_replaced(tmp_path):
    config = _config(tmp_path)
    note = RRF_FIRMWARE.apply_note_for(config)
    assert note == ("Replace the M665 line of config-override.g (line 4), the M666 line of config-override.g "
                    "(line 5) and the M92 line of config.g (line 11) with these (or send M665 and M666, then "
                    "M500; M500 does not save M92).")
    assert _written_note(config) == note
    # config-override.g without the delta lines (M500 never sent): config.g's, and M500 holds them too
    (tmp_path / "config-override.g").write_text("; config-override.g\nM307 H0 A90 C700 D5\n")
    assert RRF_FIRMWARE.apply_note_for(config).startswith(
        "Replace the M665 line of config.g (line 7), the M666 line of config.g (line 8) and the M92 line")
    assert RRF_FIRMWARE.apply_note_for(config).endswith("(or send M665 and M666, then M500; M500 does not "
                                                        "save M92).")


def test_an_m665_after_m501_is_named(tmp_path):
    config = _config(tmp_path, lambda text: text + "M665 H296.1\n")
    note = RRF_FIRMWARE.apply_note_for(config)
    assert "the M665 line of config-override.g (line 4) and the M665 line of config.g (line 19)" in note
    assert note.endswith("config.g's M665 (line 19) runs after its M501 (line 18), so M500 "
                         "(config-override.g) would not hold them.")


def test_without_the_configuration_the_note_says_both_cases():
    assert RRF_FIRMWARE.apply_note_for(None) == RRF_FIRMWARE.apply_note == APPLY_NOTE
    assert "in config-override.g when config.g runs M501 after its own" in APPLY_NOTE
    assert "else in config.g" in APPLY_NOTE
