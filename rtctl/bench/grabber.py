"""``rtctl bench grabber``: what frames cost — the driver, unpacking, the marker, the simulator.

* driver: taking the newest 512 × 512 8-bit frame from the shared buffer (claim, frame
  header, zero-copy view), and that plus unpacking it; the host's rate through that, a memory
  copy (not comparable with the paper's 13 MB/s, which is the card's transfer);
* the simulated card at the paper's 13 MB/s, for each of the 16 density modes as fields and
  as frames, on the simulator's lock-step clock: the image rate, the capture-to-readable
  latency, and when the transfer's last byte is moved (:mod:`hil_sim.transfer`);
* unpacking a 512 × 512 frame of 1, 2, 4 and 8 bits per pixel;
* the marker: the observer's work per image (kinematics, unpacking the search box, centroid);
* the simulator: posing, drawing, digitising and packing one 256 × 512 field, and in
  lock-step at 1 kHz the longest and the typical tick's share.

Goals: driver ≤ 0.5 ms per 512 × 512 8-bit frame; unpacking 1/2/4-bit ≤ 0.2 ms; the marker
≤ 0.3 ms per image. The drivers and the simulator are imported inside the functions:
``rtctl`` itself never imports them; this benchmark needs both ends of the wire.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from rtctl.bench import median_us
from rtctl.hal.framegrabber import GrabberSettings

SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "puma560_vision_sim.toml"
GOALS_US = {"driver_8bit": 500.0, "unpack_sub_byte": 200.0, "marker": 300.0}


def _memory_with_frame(settings: GrabberSettings):
    from drivers.protocols.framegrabber import CLOCK_LOOP, DevicePort, GrabberMemory, buffer_bytes
    from drivers.protocols.framegrabber_host import HostPort

    m = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
    host, dev = HostPort(m), DevicePort(m)
    host.program(settings)
    gen, regs = dev.registers()
    rng = np.random.default_rng(0)

    def publish():
        slot = dev.reserve()
        words = m.words(slot, settings)
        words.view(np.uint8)[...] = rng.integers(0, 256, words.nbytes, dtype=np.uint8).reshape(words.view(np.uint8).shape)
        dev.publish(slot, 0, "frame", gen, regs, settings.frame_bytes)

    return host, publish


def bench_driver(repeats: int = 400) -> dict:
    from drivers.protocols.framegrabber import O_LAST

    settings = GrabberSettings(scan="frame", levels=256, word_bits=32)
    host, publish = _memory_with_frame(settings)
    out = np.empty((settings.rows, settings.width), dtype=np.uint8)
    state = {"frame": None}

    def take():
        host.own[O_LAST] = 0  # the newest frame counts as unseen: every call takes it anew
        state["frame"] = host.take(0.0, 0)

    publish()
    take_us = median_us(take, repeats, 20)
    unpack_us = median_us(lambda: state["frame"].pixels(out), repeats, 20)
    mb = settings.frame_bytes / 1e6
    return {"frame_bytes": settings.frame_bytes, "take_us": take_us, "unpack_8bit_us": unpack_us,
            "driver_8bit_us": take_us + unpack_us, "throughput_mb_s": mb / ((take_us + unpack_us) * 1e-6)}


def bench_card(seconds: float = 0.12) -> dict:
    """The simulated card at the paper's rate, every mode, in lock-step at 1 kHz: what the loop
    would see (rates and latencies on the simulator's clock, so the machine's load is no factor)."""
    from drivers.protocols.framegrabber import CLOCK_LOOP, GrabberMemory, buffer_bytes
    from drivers.protocols.framegrabber_host import HostPort
    from hil_sim.camera import CameraSim
    from hil_sim.transfer import PAPER_MB_S, TransferChannel
    from rtctl.hal.framegrabber import DENSITIES

    _, _, camera, cfg, q = _observer_and_frame()
    result = {"paper_mb_s": PAPER_MB_S}
    for scan in ("fields", "frame"):
        rates, latencies, last_byte = [], [], []
        for mode in [(h, v) for h in DENSITIES for v in DENSITIES]:
            s = GrabberSettings(density=mode, scan=scan, levels=256, word_bits=8)
            m = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
            host = HostPort(m)
            host.program(s)
            sim = CameraSim(camera.renderer.scene, cfg.model, m, lambda: q, ticks_per_field=20)
            got = []
            for k in range(round(seconds * 1000)):
                sim.step(k * 1_000_000)
                frame = host.take(k * 1e-3, 0)
                if frame is not None:
                    got.append((k * 1e-3, frame.capture_time))
            rates.append((len(got) - 1) / (got[-1][1] - got[0][1]))
            latencies.extend(t - c for t, c in got)
            last_byte.append(TransferChannel(PAPER_MB_S).plan(s)[0] * 1e-6)
        result[scan] = {"hz_min": min(rates), "hz_max": max(rates), "latency_ms_min": 1e3 * min(latencies),
                        "latency_ms_max": 1e3 * max(latencies), "last_byte_ms_max": max(last_byte)}
    return result


def bench_unpack(repeats: int = 200) -> dict:
    from rtctl.vision.pixels import pack, unpack

    rng = np.random.default_rng(1)
    result = {}
    for bits in (1, 2, 4, 8):
        for word_bits in (8, 32):
            pixels = rng.integers(0, 1 << bits, (512, 512), dtype=np.uint8)
            words, out = pack(pixels, bits, word_bits), np.empty_like(pixels)
            result[f"{bits}bit_{word_bits}"] = median_us(lambda: unpack(words, bits, out), repeats, 10)
    return result


def _observer_and_frame():
    from drivers.protocols.framegrabber import CLOCK_LOOP, GrabberMemory, buffer_bytes
    from drivers.protocols.framegrabber_host import HostPort
    from hil_sim.camera import CameraSim
    from rtctl.config import load_config
    from rtctl.runtime import build

    cfg = load_config(SHIPPED, sim=True)
    rt = build(cfg)
    observer = next(c for c in rt.controllers if type(c).__name__ == "MarkerObserver")
    scene = rt.io["camera"].camera.renderer.scene
    q = np.array(cfg.sim.vector("initial_q", cfg.model.nq))
    m = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
    host = HostPort(m)
    host.program(GrabberSettings())
    camera = CameraSim(scene, cfg.model, m, lambda: q)
    camera.step(0)
    camera.step(20_000_000)
    frame = host.take(0.0, 0)
    observer.reset(rt.state)
    observer._t[0], observer._q[0], observer._k = 0.0, q, 1  # noqa: SLF001 — the pose the frame was taken in
    return observer, frame, camera, cfg, q


def bench_marker_and_sim(repeats: int = 200) -> dict:
    from drivers.protocols.framegrabber import CLOCK_LOOP, GrabberMemory, buffer_bytes
    from drivers.protocols.framegrabber_host import HostPort
    from hil_sim.camera import CameraSim
    from rtctl.vision.pixels import digitise_pack

    observer, frame, camera, cfg, q = _observer_and_frame()
    marker_us = median_us(lambda: observer.observe(frame), repeats, 10)
    marker_cpu_us = cpu_us(lambda: observer.observe(frame), repeats)
    error_px = float(np.hypot(*observer.internals["marker_error_px"]))
    r = camera.renderer
    s = GrabberSettings()
    analog = np.zeros((s.rows, s.width), dtype=np.float32)
    words = np.zeros((s.rows, s.words_per_row), dtype=np.uint32)
    band = range(0, -(-s.rows // 19))  # a field's work at 1 kHz: 19 bands after the posing tick
    pose_us = median_us(lambda: r.freeze(q, 512), repeats, 10)
    draw_us = median_us(lambda: r.draw(analog, range(0, s.rows), 0, 2, 0, 512, 512), 40, 4)
    band_us = median_us(lambda: (r.draw(analog, band, 0, 2, 0, 512, 512),
                                 digitise_pack(analog[:band.stop], s.offset, s.gain_factor, s.levels,
                                               words[:band.stop])), repeats, 10)
    # lock-step at 1 kHz: the cost of each tick's step over two seconds of fields
    m = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
    host = HostPort(m)
    host.program(s)
    lockstep = CameraSim(r.scene, cfg.model, m, lambda: q, ticks_per_field=20)
    ticks, cpu = [], []
    for k in range(2000):
        t0, c0 = time.perf_counter_ns(), time.thread_time_ns()
        lockstep.step(k * 1_000_000)
        host.take(k * 1e-3, 0)
        ticks.append(time.perf_counter_ns() - t0)
        cpu.append(time.thread_time_ns() - c0)
    ticks, cpu = np.array(ticks[100:]) / 1e3, np.array(cpu[100:]) / 1e3
    return {"marker_us": marker_us, "marker_cpu_us": marker_cpu_us, "marker_error_px": error_px, "pose_us": pose_us, "draw_field_us": draw_us,
            "field_us": pose_us + draw_us, "band_with_pack_us": band_us,
            "lockstep_tick_p50_us": float(np.median(ticks)), "lockstep_tick_p99_us": float(np.percentile(ticks, 99)),
            "lockstep_tick_max_us": float(ticks.max()), "lockstep_field_us": float(ticks.sum() / (ticks.size / 20)),
            "lockstep_cpu_p50_us": float(np.median(cpu)), "lockstep_cpu_p99_us": float(np.percentile(cpu, 99)),
            "lockstep_cpu_max_us": float(cpu.max())}


def cpu_us(fn, calls: int) -> float:
    """This process's CPU time per call (µs): what the work costs when the machine is busy with others."""
    fn()
    t0 = time.process_time_ns()
    for _ in range(calls):
        fn()
    return (time.process_time_ns() - t0) / calls / 1e3


def bench_grabber() -> dict:
    from rtctl import logs

    logs.configure("json", level="warning")
    result = {"driver": bench_driver(), "unpack_us": bench_unpack(), "sim": bench_marker_and_sim(), "card": bench_card(),
              "goals_us": GOALS_US}
    result["loadavg_1min"] = os.getloadavg()[0]
    return result


def _ok(value: float, goal: float) -> str:
    return "ok" if value <= goal else "MISSED"


def format_table(result: dict) -> str:
    d, u, s, g = result["driver"], result["unpack_us"], result["sim"], result["goals_us"]
    sub_byte = max(v for k, v in u.items() if not k.startswith("8bit"))
    lines = [f"rtctl bench grabber — medians (µs); load average {result['loadavg_1min']:.2f} "
             f"(on a busy machine compare the CPU time)",
             f"  {'driver: take newest 512×512 8-bit frame (zero-copy)':<58}{d['take_us']:9.1f}",
             f"  {'driver: + unpack to grey levels':<58}{d['driver_8bit_us']:9.1f}   goal ≤ {g['driver_8bit']:g}  "
             f"{_ok(d['driver_8bit_us'], g['driver_8bit'])}",
             f"  {'driver: host copy rate from the buffer (MB/s)':<58}{d['throughput_mb_s']:9.0f}   a memory copy, "
             f"not the card's transfer",
             "  unpack 512×512:  " + ", ".join(f"{k.replace('_', ' in ')}-bit words {v:.1f}" for k, v in u.items()),
             f"  {'unpack 1/2/4-bit, worst':<58}{sub_byte:9.1f}   goal ≤ {g['unpack_sub_byte']:g}  "
             f"{_ok(sub_byte, g['unpack_sub_byte'])}",
             f"  {'marker: observer per image':<58}{s['marker_us']:9.1f}   goal ≤ {g['marker']:g}  "
             f"{_ok(s['marker_us'], g['marker'])}  (CPU {s['marker_cpu_us']:.1f}; error {s['marker_error_px']:.2f} px)",
             f"  {'simulator: pose a field (kinematics, projection)':<58}{s['pose_us']:9.1f}",
             f"  {'simulator: draw a 256×512 field':<58}{s['draw_field_us']:9.1f}",
             f"  {'simulator: a whole field (pose + draw)':<58}{s['field_us']:9.1f}",
             f"  {'simulator: a band, drawn, digitised and packed (1/19 field)':<58}{s['band_with_pack_us']:9.1f}",
             f"  simulator in lock-step at 1 kHz, per tick: p50 {s['lockstep_tick_p50_us']:.1f}, "
             f"p99 {s['lockstep_tick_p99_us']:.1f}, max {s['lockstep_tick_max_us']:.1f}; "
             f"per field {s['lockstep_field_us']:.0f}",
             f"    CPU time per tick: p50 {s['lockstep_cpu_p50_us']:.1f}, p99 {s['lockstep_cpu_p99_us']:.1f}, "
             f"max {s['lockstep_cpu_max_us']:.1f} (the tick that poses a field, one in 20)"]
    c = result["card"]
    lines.append(f"  simulated card at the paper's {c['paper_mb_s']:g} MB/s, the 16 modes, 8-bit, on the lock-step clock:")
    for scan, what in (("fields", "fields"), ("frame", "frames")):
        r = c[scan]
        lines.append(f"    {what:<7} {r['hz_min']:.1f}–{r['hz_max']:.1f} Hz, capture → readable "
                     f"{r['latency_ms_min']:.1f}–{r['latency_ms_max']:.1f} ms, last byte moved by "
                     f"{r['last_byte_ms_max']:.2f} ms (modelled)")
    return "\n".join(lines)
