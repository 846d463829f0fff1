"""Tests for the vision and framegrabber-protocol mutants that survived the suite (part 4, the
full run; docs/mutation/vision.md). Each expectation comes from the documented protocol and defaults:

* a host that loses the race for a slot (the device took it back between the host's claim and
  its second look) withdraws its claim: the claim word is −1 again, nothing is held, and the
  device may reserve that slot (a claim left on slot 1 kept the device off it);
* a device with no free slot skips the frame and counts it;
* the device status names each of the four states, FAULT included, and a wild one as such;
* the camera's principal point defaults to the centre of the 512-pixel screen, (255.5, 255.5):
  the point it looks at projects there.
"""
import numpy as np
import pytest

from drivers.protocols import framegrabber
from drivers.protocols.framegrabber import BUSY, FAULT, H_CLAIM, H_HOLD, IDLE, RACE, S_STATE, W_SEQ0, host_claim
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.vision.camera import Camera
from vision_rig import programmed_pair

SETTINGS = GrabberSettings(density=64, scan="frame", word_bits=8)


class _TakenBackAfterOneLook:
    """The device's words, where the device reserves ``slot`` again (BUSY) just after the
    host's first look at its sequence number: the race the claim's second look is for."""

    def __init__(self, words, slot):
        self.words, self.slot, self.looks = words, slot, 0

    def __getitem__(self, i):
        value = self.words[i]
        if i == W_SEQ0 + self.slot:
            self.looks += 1
            if self.looks == 1:
                self.words[i] = BUSY
        return value


def test_a_host_that_loses_the_race_for_a_slot_withdraws_its_claim(monkeypatch):
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    slot = dev.reserve()
    dev.publish(slot, 0, "frame", gen, regs, SETTINGS.frame_bytes)
    writer = _TakenBackAfterOneLook(memory.writer, slot)
    m = memory
    with monkeypatch.context() as patch:  # the claim's Python body, one thread: no fence needed
        patch.setattr(framegrabber, "_fence", lambda: None)  # (only around it: kernels compiled now would see it)
        got = host_claim.py_func(m.ident, host.expected, m.status, writer, m.reader, host.own, m.n_slots)
    assert got == RACE and writer.looks == 2
    assert m.reader[H_CLAIM] == -1 and m.reader[H_HOLD] == -1
    # slot 0 is published (and BUSY again); nothing is held or claimed: the other three are free
    assert slot == 0 and [dev.reserve() for _ in range(3)] == [1, 2, 3] and dev.skipped == 0


def test_a_device_with_no_free_slot_skips_the_frame_and_counts_it():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    first = dev.reserve()
    dev.publish(first, 0, "frame", gen, regs, SETTINGS.frame_bytes)  # published
    assert host.claim() == first  # held (and still published)
    busy = [dev.reserve(), dev.reserve(), dev.reserve()]  # the other three, being written
    assert sorted(busy + [first]) == list(range(memory.n_slots)) and dev.skipped == 0
    assert dev.reserve() == -1 and dev.skipped == 1
    assert dev.reserve() == -1 and dev.skipped == 2
    dev.abandon(busy[0])
    assert dev.reserve() == busy[0] and dev.skipped == 2


@pytest.mark.parametrize(("state", "name"), [(0, "idle"), (1, "running"), (2, "done"), (3, "fault"),
                                             (4, "<state 4>"), (-1, "<state -1>")])
def test_the_device_status_names_its_state(state, name):
    memory, host, *_ = programmed_pair(SETTINGS)
    assert (IDLE, FAULT) == (0, 3)
    memory.status[S_STATE] = state
    assert host.device_status()["state"] == name


def test_the_principal_point_defaults_to_the_screens_centre():
    from rtctl.tomltable import Table

    look_at = [0.35, 0.05, 0.0]
    camera = Camera.from_table(Table({"position": [1.7, -1.2, 0.9], "look_at": look_at, "focal_px": 760.0},
                                     "camera.toml", "camera"))
    np.testing.assert_allclose(camera.project(np.array(look_at)), [255.5, 255.5], atol=1e-9)
