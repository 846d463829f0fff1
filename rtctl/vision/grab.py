"""``rtctl grab CONFIG -o frame.png``: one image of a framegrabber device, saved as a picture.

Only the framegrabber is brought up (joint devices are built, never configured: no drive is
touched). A simulated one (``[sim]`` or ``--sim``) is stepped in lock-step, the robot at its
initial pose; a real one is polled on the wall clock. Grey levels are stretched to 0 … 255; a
single field is line-doubled, as a monitor shows it, and on a grid whose horizontal and
vertical densities differ the coarser axis's pixels are repeated, so the picture keeps its aspect.
"""
from __future__ import annotations

import time

import numpy as np

from rtctl.errors import HardwareError, RtctlError
from rtctl.hal.framegrabber import FrameGrabber


def _image(frame) -> np.ndarray:
    s = frame.settings
    levels = frame.pixels()
    if s.levels != 256:
        levels = (levels.astype(np.uint16) * 255 // (s.levels - 1)).astype(np.uint8)
    row_height = (2 if frame.field != "frame" else 1) * s.density_h  # ∝ a row's height on the screen …
    col_width = s.density_v  # … and a column's width (both × 512 / (h·v)): powers of two
    square = min(row_height, col_width)
    return np.repeat(np.repeat(levels, row_height // square, axis=0), col_width // square, axis=1)


def save_png(frame, path) -> None:
    try:
        from PIL import Image
    except ImportError:
        raise RtctlError("saving a picture needs Pillow, in the optional extra `vision`: "
                         "pip install 'rtctl[vision]'") from None
    Image.fromarray(_image(frame), mode="L").save(path)


def grab_frame(runtime, device: str | None, timeout_s: float):
    """Bring the framegrabber up, wait for its first image, close it → (device name, frame copy)."""
    grabbers = {n: d for n, d in runtime.io.items() if isinstance(d, FrameGrabber)}
    if not grabbers or (device is not None and device not in grabbers):
        raise RtctlError(f"{runtime.cfg.file}: " + (f"no framegrabber device named {device!r}; " if device else "")
                         + f"framegrabber devices: {', '.join(grabbers) or 'none'}")
    name = device or next(iter(grabbers))
    grabber = grabbers[name]
    lockstep = runtime.cfg.sim is not None
    period = runtime.cfg.loop.period
    try:
        grabber.configure()
        warm_up = getattr(grabber, "warm_up", None)
        if warm_up is not None:
            warm_up()
        grabber.activate()
        t0, t = time.monotonic(), 0.0
        while t <= timeout_s:
            if grabber.read(t) != 0:
                raise HardwareError(f"{name}: {grabber.last_error}")
            frame = grabber.grab()
            if frame is not None:
                return name, frame.copy()
            if lockstep:
                t += period
            else:
                time.sleep(period)
                t = time.monotonic() - t0
        raise HardwareError(f"{name}: no image within {timeout_s:g} s of {'simulated' if lockstep else 'wall'} time")
    finally:
        grabber.close()


def grab(args) -> int:
    from rtctl.config import load_config
    from rtctl.runtime import build

    from rtctl.outputs import output_path

    out = output_path(args.output, "--output", suffixes=(".png",), default_suffix=".png")
    cfg = load_config(args.config, sim=args.sim)
    name, frame = grab_frame(build(cfg), args.device, args.timeout)
    save_png(frame, out)
    print(f"{out}: {name}: {frame!r}")
    return 0
