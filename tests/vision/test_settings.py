"""The framegrabber's settings: what the paper's interface can do is accepted, every other
combination is refused naming the key — and in a configuration, naming file and key path."""
import pytest

from rtctl.config import load_config
from rtctl.errors import ConfigError, SettingsError
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.runtime import build

VALID = [
    dict(),  # 512 × 512, every field, 256 levels in 32-bit words
    dict(density=64, window=(0, 0, 64, 64), scan="frame", levels=2, word_bits=8),
    dict(density=128, window=(32, 16, 64, 32), scan="odd", levels=4, word_bits=16),
    dict(density=256, window=(8, 10, 16, 2), scan="even", levels=16, word_bits=8),
    dict(density=512, window=(480, 0, 32, 511), scan="frame", levels=2, word_bits=32),
    dict(offset=255, gain=0), dict(offset=0, gain=255),
    dict(density=64, scan="frame", shots=64),  # 64 frames of 4 KiB fill the 256 KiB exactly
    dict(shots=1),  # one 512 × 256 field of 128 KiB
]

INVALID = [
    (dict(density=1024), "density", "2^k with k = 6..9"),
    (dict(density=100), "density", "got 100"),
    (dict(density=256, window=(0, 0, 512, 256)), "window", "inside the 256 × 256 grid"),
    (dict(density=256, window=(200, 0, 64, 64)), "window", "x + width ≤ 256"),
    (dict(window=(0, 500, 64, 14)), "window", "y + height ≤ 512"),
    (dict(window=(-2, 0, 64, 64)), "window", "x, y ≥ 0"),
    (dict(window=(0, 0, 0, 64)), "window", "width, height ≥ 1"),
    (dict(window=(0, 1, 64, 64), scan="odd"), "window", "an even y and height for a single field"),
    (dict(window=(0, 0, 64, 63), scan="fields"), "window", "an even y and height"),
    (dict(window=(0, 0, 100, 64), levels=2, word_bits=32), "window", "width a multiple of 32"),
    (dict(window=(0, 0, 5, 64), levels=256, word_bits=16), "window", "width a multiple of 2"),
    (dict(window=(0, 0, 12, 64), levels=4, word_bits=32), "window", "width a multiple of 16"),
    (dict(scan="interlaced"), "scan", "one of 'odd', 'even', 'fields', 'frame'"),
    (dict(offset=256), "offset", "0..255"),
    (dict(gain=-1), "gain", "0..255"),
    (dict(levels=8), "levels", "2, 4, 16 or 256"),
    (dict(levels=65536), "levels", "2, 4, 16 or 256"),
    (dict(word_bits=64), "word_bits", "8, 16 or 32"),
    (dict(shots=-1), "shots", "0 (continuous)"),
    (dict(scan="frame", shots=2), "shots", "within the 256 KiB on-board memory (at most 1"),
    (dict(density=64, scan="frame", shots=65), "shots", "at most 64"),
    (dict(density=512.0), "density", "an integer"),
    (dict(window=(0, 0, 64)), "window", "[x, y, width, height]"),
    (dict(gain=True), "gain", "an integer"),
]


@pytest.mark.parametrize("kw", VALID, ids=[str(k) for k in VALID])
def test_valid_settings(kw):
    s = GrabberSettings(**kw)
    x, y, w, h = s.window
    assert x + w <= s.density and y + h <= s.density
    assert s.words_per_row * s.word_bits == s.width * s.bits
    assert s.frame_bytes * max(s.shots, 1) <= 256 * 1024


@pytest.mark.parametrize("kw, key, message", INVALID, ids=[f"{k}-{m[:20]}" for _, k, m in INVALID])
def test_invalid_settings_refused_naming_the_key(kw, key, message):
    with pytest.raises(SettingsError) as e:
        GrabberSettings(**kw)
    assert e.value.key.split(".")[0] == key
    assert message in str(e.value)


def test_derived_sizes():
    s = GrabberSettings(density=256, window=(16, 8, 128, 64), scan="odd", levels=16, word_bits=16)
    assert (s.rows, s.width, s.bits, s.words_per_row, s.frame_bytes) == (32, 128, 4, 32, 2048)
    assert s.period_s == 0.04 and GrabberSettings(scan="fields").period_s == 0.02
    assert GrabberSettings(gain=192).gain_factor == 2.0 and GrabberSettings(gain=64).gain_factor == 0.5


CONFIG = """
[robot]
description = "{robot}"
[loop]
realtime_factor = 0.0
[sim]
[[devices]]
name = "camera"
kind = "framegrabber"
driver = "framegrabber"
[devices.settings]
{settings}
[devices.scene.camera]
position = [1.7, -1.2, 0.9]
look_at = [0.35, 0.05, 0.0]
"""


@pytest.mark.parametrize("settings, key_path, message", [
    ("density = 512\nwindow = [0, 0, 600, 512]", "devices[0].settings.window", "inside the 512 × 512 grid"),
    ("levels = 256\nword_bits = 32\nwindow = [0, 0, 30, 64]", "devices[0].settings.window", "multiple of 4"),
    ("levels = 3", "devices[0].settings.levels", "2, 4, 16 or 256"),
    ("scn = 'odd'", "devices[0].settings.scn", "unknown key"),
    ("window = [0, 0]", "devices[0].settings.window", "[x, y, width, height]"),
])
def test_bad_settings_in_a_config_name_file_and_key(tmp_path, settings, key_path, message):
    from runtime_helpers import PUMA

    path = tmp_path / "vision.toml"
    path.write_text(CONFIG.format(robot=PUMA, settings=settings))
    with pytest.raises(ConfigError) as e:
        build(load_config(path))
    assert e.value.key_path == key_path and message in e.value.expected and e.value.file == str(path)


def test_bad_settings_exit_2_before_anything_opens(tmp_path):
    from runtime_helpers import PUMA, rtctl

    path = tmp_path / "vision.toml"
    path.write_text(CONFIG.format(robot=PUMA, settings="density = 48"))
    for cmd in (("check",), ("run", "--duration", "0.1"), ("grab", "-o", tmp_path / "f.png")):
        r = rtctl(*cmd[:1], path, *cmd[1:])
        assert r.returncode == 2, (cmd, r.stderr)
        assert "devices[0].settings.density" in r.stderr and "k = 6..9" in r.stderr and str(path) in r.stderr
    assert not (tmp_path / "f.png").exists()
