"""The framegrabber over HIL: ``hil-sim``'s free-running camera in its own process, the
``framegrabber`` driver attached to its shared memory in this one.

Stated bounds (loose: the machine is shared): over 2 s, fields arrive at 50 Hz ± 10 % and
frames at 25 Hz ± 10 % (the rate of arrivals at the host); the intervals between capture
stamps are whole fields — 20 ms (fields) or 40 ms (frames) — give or take the camera
thread's late wake-ups (≤ 5 ms), a skipped field at most 1 in 10; the latency from capture to
the host is a field (20 ms) or a frame (40 ms), median within −5 … +5 ms. Nothing is dropped
by a host polling every millisecond. A bound missed while the record shows the machine stalled
is a VmStall, retried like the other HIL tests': the camera skipped fields or woke later than
its 5 ms, or the host's polling paused longer than an image less those 5 ms (two images, the
first written late and the next on time, can then complete between two reads: a drop).
"""
import time

import numpy as np
import pytest

from drivers.framegrabber import ShmFrameGrabber
from hil_helpers import CONFIGS, VmStall
from rtctl.hal.framegrabber import GrabberSettings

pytestmark = pytest.mark.hil
CAMERA_LATE_S = 0.005  # the camera thread's wake-up lateness this file states (module docstring)


def _collect(grabber, t0, seconds):
    """Poll every millisecond until ``seconds`` of loop time (monotonic − t0) have passed."""
    got, polls = [], []
    while (t := time.monotonic() - t0) < seconds:
        polls.append(t)
        assert grabber.read(t) == 0, grabber.last_error
        frame = grabber.grab()
        if frame is not None:
            got.append((t, frame.capture_time, frame.field, frame.seq))
        grabber.write(t)
        time.sleep(0.001)
    return (np.array([g[0] for g in got]), np.array([g[1] for g in got]), [g[2] for g in got],
            float(np.diff(polls).max()) if len(polls) > 1 else 0.0)  # (a stall may leave no poll at all)


@pytest.mark.parametrize("scan, rate_hz, latency_s", [("fields", 50.0, 0.020), ("frame", 25.0, 0.040)])
def test_free_running_fields_and_frames_at_the_pal_rate(hil_sim, scan, rate_hz, latency_s):
    sim = hil_sim(CONFIGS / "puma560_vision_sim.toml", "--realtime-factor", "1")
    shm = sim.info["env"]["HIL_SIM_FRAMEGRABBER"]
    assert sim.info["framegrabbers"]["camera"]["shm"] == shm
    grabber = ShmFrameGrabber("camera", GrabberSettings(density=256, scan=scan), shm)
    try:
        grabber.configure()
        grabber.activate()
        t0 = time.monotonic()  # the loop's clock
        _collect(grabber, t0, 0.2)  # the device takes the program at its next field
        arrivals, captures, fields, poll_gap = _collect(grabber, t0, 2.2)
        counts = dict(grabber.diagnostics())
    finally:
        grabber.close()
    exit_event = sim.stop()
    camera = exit_event["framegrabbers"]["camera"]
    assert camera["images"] >= counts["frames"] and camera["settings_errors"] == 0
    steps = np.diff(captures) / (1 / rate_hz)
    camera_late = float(np.max(np.abs(steps - np.round(steps)), initial=0.0)) / rate_hz
    try:
        np.testing.assert_allclose(steps, np.round(steps), atol=CAMERA_LATE_S * rate_hz)  # whole images, ± 5 ms
        assert set(fields) == ({"odd", "even"} if scan == "fields" else {"frame"})
        n = arrivals.size
        assert n >= 0.9 * 2.0 * rate_hz
        measured_hz = (n - 1) / (arrivals[-1] - arrivals[0])
        assert measured_hz == pytest.approx(rate_hz, rel=0.10)
        assert np.mean(np.round(steps) > 1) <= 0.1
        latency = arrivals - captures
        assert latency_s - 0.005 <= np.median(latency) <= latency_s + 0.005
        assert counts["dropped"] == 0
    except AssertionError as e:
        if camera["missed_fields"] or camera_late > CAMERA_LATE_S or poll_gap > 1 / rate_hz - CAMERA_LATE_S:
            raise VmStall(f"machine stall (camera missed {camera['missed_fields']} fields, woke up to "
                          f"{camera_late * 1e3:.1f} ms late; host paused {poll_gap * 1e3:.0f} ms): {e}") from e
        raise
    print(f"{scan}: {measured_hz:.2f} Hz, latency median {np.median(latency) * 1e3:.1f} ms, "
          f"p90 {np.percentile(latency, 90) * 1e3:.1f} ms, {n} images, skipped {np.mean(np.round(steps) > 1):.0%}")


CAMERA_AND_OBSERVER = """
[[devices]]
name = "camera"
kind = "framegrabber"
driver = "framegrabber"
shm = "${HIL_SIM_FRAMEGRABBER:-rtctl-framegrabber}"
[devices.settings]
scan = "fields"
[devices.scene.camera]
position = [1.7, -1.2, 0.9]
look_at = [0.35, 0.05, 0.0]
focal_px = 760.0

[[controllers]]
name = "marker"
type = "marker_observer"
joints = []
devices = ["camera"]
[controllers.camera]
position = [1.7, -1.2, 0.9]
look_at = [0.35, 0.05, 0.0]
focal_px = 760.0
"""


def test_marker_observed_in_a_run_against_hil_sim(hil_sim, tmp_path):
    """`rtctl run` on CAN drives over socketcand with the camera over shared memory, both played
    by hil-sim in its own process (lock-step plant, free-running camera): every field is
    observed and the marker found in each; what the camera saw agrees with the loop's record of
    the joints up to a time shift ``lag`` (the loop's joint measurements against the plant),
    within 1 px RMS once that shift is taken out. The shift is printed: a field or less here
    (measured 13-18 ms on the shared test machine; see the note in docs/framegrabber.md)."""
    from hil_helpers import STALL_TOLERANT, run, unless_stalled, variant

    config = variant(tmp_path, "puma560_hil_socketcand.toml", **STALL_TOLERANT)
    config.write_text(config.read_text().replace("[safety]", CAMERA_AND_OBSERVER + "\n[safety]"))
    sim = hil_sim(config, "--port", 0)
    code, summary, tel, err = run(config, tmp_path, sim.env(), duration=3.0)
    sim.stop()
    camera = summary["devices"]["camera"]
    seq = tel["marker_seq"]
    numbers, first = np.unique(seq, return_index=True)
    first = first[numbers > 0]  # (0: no image yet; the device numbers its images from 1)
    with unless_stalled(summary):  # a stalled loop may end before any field: say so, not IndexError
        assert len(first) >= 3, (f"{len(first)} fields observed in {len(seq)} ticks, exit {code} "
                                 f"({summary['stop_reason']})", err[-2000:])
    error = tel["marker_error_px"][first]
    t, predicted = tel["marker_capture_t"][first], tel["marker_predicted_px"][first]
    velocity = np.gradient(predicted, t, axis=0)  # px/s of the marker, from the loop's joints
    lag = float(np.sum(error * velocity) / np.sum(velocity * velocity))
    residual = error - lag * velocity
    rms, rms_shifted = (float(np.sqrt(np.mean(np.sum(e ** 2, axis=1)))) for e in (error, residual))
    print(f"HIL: {camera['frames']} images, {camera['dropped']} dropped, marker RMS {rms:.2f} px; the camera "
          f"matches the loop's joints {lag * 1e3:+.1f} ms later, then RMS {rms_shifted:.2f} px")
    assert camera["device"]["state"] == "running" and camera["device"]["settings_errors"] == 0
    assert not np.isnan(error).any()
    with unless_stalled(summary):  # (a stalled writer drops telemetry rows: an image's rows with them)
        assert len(first) == camera["frames"]
    # every image the device completed while the loop ran was taken or counted dropped (a
    # stalled loop drops): only those completed after the loop's last read are in neither
    written = camera["device"]["written"]
    assert camera["frames"] + camera["dropped"] <= written
    with unless_stalled(summary):  # (a loop stalled near its end leaves more than 3 images unread)
        assert written - 3 <= camera["frames"] + camera["dropped"]
        assert code == 0, (summary["stop_reason"], err[-2000:])
        assert camera["frames"] >= 0.9 * 50 * 3.0 and camera["dropped"] <= 0.1 * camera["frames"]
        assert abs(lag) <= 0.025 and rms_shifted <= 1.0


@pytest.mark.parametrize("garbage", ["slot 2^40", "random header"])
def test_a_wild_shm_slot_index_or_header_in_a_run_is_a_controlled_stop_naming_the_camera(hil_sim, tmp_path, garbage):
    """Defect 1 of issue 25: garbage written into the grabber's shared memory during a run
    killed the daemon (SIGSEGV, exit 139: no controlled stop, drives left enabled, no summary,
    the socket file left behind). Now it is the camera's fault: the run stops as after any
    fault (exit 3), the fault names the camera and the word, the drives are switched off by
    command (not by their watchdog), and the socket is gone."""
    import json
    import os

    from drivers.framegrabber import attach_shared_memory
    from drivers.protocols.framegrabber import HEADER_BYTES, W_PUBLISHED, GrabberMemory
    from hil_helpers import STALL_TOLERANT, Daemon, loop_time, variant, wait_for

    config = variant(tmp_path, "puma560_hil_socketcand.toml", **STALL_TOLERANT)
    config.write_text(config.read_text().replace("[safety]", CAMERA_AND_OBSERVER + "\n[safety]"))
    sim = hil_sim(config, "--port", 0)
    saved = dict(os.environ)
    os.environ.update(sim.env())  # the Daemon helper inherits the environment
    try:
        d = Daemon(config, tmp_path, "--duration", 20, "--telemetry", tmp_path / "run.msgpack")
    finally:
        os.environ.clear()
        os.environ.update(saved)
    shm = attach_shared_memory(sim.info["env"]["HIL_SIM_FRAMEGRABBER"])
    try:
        assert wait_for(lambda: loop_time(d) > 0.5 or d.proc.poll() is not None, timeout=90)
        if garbage == "slot 2^40":
            writer = GrabberMemory(shm.buf).writer
            for _ in range(100):  # for 0.1 s: the camera publishes a slot every 20 ms
                writer[W_PUBLISHED] = 2 ** 40
                time.sleep(0.001)
            del writer
        else:
            header = np.ndarray((HEADER_BYTES,), dtype=np.uint8, buffer=shm.buf)
            header[:] = np.random.default_rng(25).integers(0, 256, HEADER_BYTES, dtype=np.uint8)
            del header
        code, out, err = d.finish(timeout=60)
    finally:
        d.kill()
        shm.close()
    exit_event = sim.stop()
    assert code == 3, (code, err[-3000:])
    summary = json.loads(d.summary.read_text())
    fault = summary["safety"]["faults"][0]
    cause = "published slot index 1099511627776" if garbage == "slot 2^40" else "layout word 0 changed"
    assert fault["kind"] == "device_error" and fault["reason"].startswith("device camera failed: "), fault
    assert cause in fault["reason"], fault
    assert not d.socket.exists()
    assert not any(drive["enabled"] for drive in exit_event["drives"])
    assert {e["cause"] for e in sim.of("motor_off")} == {"command"}  # off by the daemon, not a watchdog
