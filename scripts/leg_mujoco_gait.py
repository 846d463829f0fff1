#!/usr/bin/env python3
"""The leg automaton on both leg plants — the scripted gait generator (configs/leg_sim.toml) and
the leg on MuJoCo's contact physics (configs/leg_mujoco.toml) — walked tick by tick as the loop
does (board read → automaton → board write), and the gait plot of docs/mujoco.md:

    python scripts/leg_mujoco_gait.py                      # 51 periods on each: the state sequences
    python scripts/leg_mujoco_gait.py --plot docs/img/leg_mujoco_gait.png
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rtctl.config import load_config  # noqa: E402
from rtctl.runtime import build  # noqa: E402

PATTERN = (1, 2, 3, 4, 1, 5, 1, 6)
CONFIGS = {"scripted": ROOT / "configs" / "leg_sim.toml", "MuJoCo": ROOT / "configs" / "leg_mujoco.toml"}


def pattern_prefix(seq) -> int:
    """How many states of ``seq`` follow (1 2 3 4 1 5 1 6)ⁿ from the start (state 1)."""
    n = 0
    while n < len(seq) and seq[n] == PATTERN[n % len(PATTERN)]:
        n += 1
    return n


def walk(config: Path, seconds: float, record: bool = False):
    """The automaton's state sequence (each change once) over ``seconds`` of plant time; with
    ``record``, the per-tick trace (t, hip, knee, ankle in degrees, toe, heel loads, state) too."""
    rt = build(load_config(config))
    board, ctl = rt.devices[0], rt.controllers[0]
    board.configure()
    board.activate()
    ctl.reset(None)
    plant = board.plant
    ticks = int(round(seconds / board.period))
    trace = np.zeros((ticks, 7)) if record else None
    seq = [int(ctl.data[4])]
    for k in range(ticks):
        board.read(0.0)
        ctl.update(0.0, None, None, None)
        board.write(0.0)
        state = int(ctl.data[4])
        if state != seq[-1]:
            seq.append(state)
        if record:
            trace[k, 0] = plant.time
            trace[k, 1:4] = plant.q
            trace[k, 4:6] = plant.loads
            trace[k, 6] = state
    board.close()
    if record:
        trace[:, 1:4] *= 180.0 / math.pi
    return seq, trace


def plot(traces: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    for name, tr in traces.items():
        style = "-" if name == "MuJoCo" else ":"
        for col, label, color in ((1, "hip", "C0"), (2, "knee", "C1"), (3, "ankle", "C2")):
            axes[0].plot(tr[:, 0], tr[:, col], style, color=color, lw=1, label=f"{label} ({name})")
        axes[1 if name == "MuJoCo" else 2].plot(tr[:, 0], tr[:, 4], color="C3", lw=1, label="toe")
        axes[1 if name == "MuJoCo" else 2].plot(tr[:, 0], tr[:, 5], color="C4", lw=1, label="heel")
        axes[3].step(tr[:, 0], tr[:, 6], style, where="post", lw=1.2, label=name)
    axes[0].set_ylabel("angle (deg)")
    axes[0].legend(fontsize=7, ncol=2, loc="upper right")
    for ax, title in ((axes[1], "MuJoCo: normal contact force"), (axes[2], "scripted: penetration / contact_depth")):
        ax.axhline(0.15, color="k", lw=0.6, ls="--")
        ax.set_ylabel("load (body weights)")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=7, loc="upper right")
    axes[3].set_ylabel("automaton state")
    axes[3].set_xlabel("t (s)")
    axes[3].legend(fontsize=7, loc="upper right")
    fig.suptitle("The leg automaton on the scripted leg and on MuJoCo (gate thresholds unchanged; toe/heel gate at 0.15)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--periods", type=float, default=51.0, help="gait periods of 1.2 s (default 51)")
    ap.add_argument("--plot", type=Path, help="PNG of the first 4 periods on both plants")
    args = ap.parse_args()
    for name, config in CONFIGS.items():
        seq, _ = walk(config, args.periods * 1.2)
        good = pattern_prefix(seq)
        print(f"{name}: {len(seq)} states, {(good - 1) // len(PATTERN)} complete (1 2 3 4 1 5 1 6) cycles, "
              f"{len(seq) - good} off the sequence")
    if args.plot:
        plot({name: walk(config, 4 * 1.2, record=True)[1] for name, config in CONFIGS.items()}, args.plot)
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
