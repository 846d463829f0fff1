"""Tests for vision mutants that survived the full run's fast pass (part 13; docs/mutation/vision.md):

* the camera: a focal length of 0 is refused by ``Camera.looking_at`` (a ValueError) and, in a
  configuration, by name (``focal_px``, not the ``look_at`` that the camera's own check names);
* the observer's search box: its half-size in columns is rounded up as its rows' is (32.5 screen
  px at density 512: ±33 columns), not rounded down first;
* the host refuses a frame whose field its scan does not deliver (an odd field from a frame
  scan), not only a field code out of range;
* the search box is at least ±2 image rows as it is ±2 columns, and a guess whose box lies
  wholly outside the image measures nothing (False, not a NaN taken as found);
* the one-pass digitiser and packer gives what ``digitise`` then ``pack`` give, with a black
  offset too (its offset was only ever 0 there);
* the registers give back every setting written, each from its own word (a window whose x and
  y differ: decode took x from y's word, and every setting used so far had x = y).
"""
import numpy as np
import pytest

from drivers.protocols.framegrabber import FIELD_NAMES, decode, encode
from rtctl.errors import ConfigError, ProtocolError
from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.model import load_robot
from rtctl.tomltable import Table
from rtctl.vision.camera import Camera
from rtctl.vision.pixels import digitise, digitise_pack, pack, unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, programmed_pair

PLACE = {"position": [1.7, -1.2, 0.9], "look_at": [0.35, 0.05, 0.0]}


def test_a_focal_length_of_zero_is_refused():
    with pytest.raises(ValueError, match="focal length must be positive"):
        Camera.looking_at(PLACE["position"], PLACE["look_at"], 0.0)
    with pytest.raises(ConfigError) as e:
        Camera.from_table(Table(dict(PLACE, focal_px=0.0), "camera.toml", "camera"))
    assert e.value.key_path.endswith("focal_px")


@pytest.mark.parametrize("cols_away, found", [(33, True), (34, False)])
def test_the_boxs_half_size_in_columns_is_rounded_up(cols_away, found):
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=32.5)
    settings = GrabberSettings(density=512, scan="frame", word_bits=8)
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[100, 200 + cols_away] = 250
    guess = Camera.to_screen(np.array([200.0, 100.0]), settings.density)
    assert observer.measure(Frame(1, 0.0, "frame", settings, words, unpack), guess, np.zeros(2)) is found


@pytest.mark.parametrize("scan, field", [("frame", "odd"), ("odd", "even"), ("fields", "frame")])
def test_a_field_its_scan_does_not_deliver_is_refused(scan, field):
    settings = GrabberSettings(density=64, scan=scan, word_bits=8)
    memory, host, dev, gen, regs = programmed_pair(settings)
    dev.publish(dev.reserve(), 0, field, gen, regs, settings.frame_bytes)
    with pytest.raises(ProtocolError, match=f"field code {FIELD_NAMES.index(field)}, scan '{scan}'"):
        host.take(0.0, 0)


def test_the_registers_give_back_every_setting_each_from_its_own_word():
    settings = GrabberSettings(density=(256, 128), window=(16, 48, 96, 64), scan="odd", offset=3, gain=140,
                               levels=16, word_bits=16, shots=5)
    assert decode(encode(settings, 7)) == settings


def _measure(settings, marker_row, marker_col, guess_col, guess_row, search_px):
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=search_px)
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[marker_row, marker_col] = 250
    guess = Camera.to_screen(np.array([guess_col, guess_row]), settings.density)
    out = np.zeros(2)
    return observer.measure(Frame(1, 0.0, "frame", settings, words, unpack), guess, out), out


@pytest.mark.parametrize("rows_away, found", [(2, True), (3, False)])
def test_the_box_is_at_least_two_image_rows_either_way(rows_away, found):
    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    assert _measure(settings, 20 + rows_away, 30, 30.0, 20.0, search_px=1.0)[0] is found


def test_a_box_wholly_below_the_image_measures_nothing():
    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    found, out = _measure(settings, 60, 30, 30.0, 200.0, search_px=1.0)
    assert found is False and np.isnan(out).all()


@pytest.mark.parametrize("offset", [0, 1, 100, 255])
def test_digitising_and_packing_in_one_pass_is_both_in_turn_with_a_black_offset(offset):
    rng = np.random.default_rng(offset)
    analog = rng.uniform(0.0, 1.0, (4, 32)).astype(np.float32)
    levels = np.zeros(analog.shape, dtype=np.uint8)
    digitise(analog, offset, 1.0, 16, levels)
    expected = pack(levels, 4, 16)
    np.testing.assert_array_equal(digitise_pack(analog, offset, 1.0, 16, np.zeros_like(expected)), expected)
