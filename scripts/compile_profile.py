"""What a run's first start compiles, and how long each kernel takes: the warm-up groups of a
run configuration, run one after another in this process, with numba's compile events.

    NUMBA_CACHE_DIR=$(mktemp -d) .venv/bin/python scripts/compile_profile.py configs/puma560_cstar_sim.toml

A fresh NUMBA_CACHE_DIR makes it a cold start; times include the kernels each one calls.
"""
import sys
import time
import types

from numba.core.event import install_recorder

from rtctl.daemon import prepare
from rtctl.start_up import warm_up_groups


def main(config: str) -> None:
    daemon = prepare(types.SimpleNamespace(config=config, sim=None, realtime_factor=None))
    for name, fn in warm_up_groups(daemon):
        t0 = time.perf_counter()
        with install_recorder("numba:compile") as recorder:
            fn()
        starts, rows = {}, []
        for ts, ev in recorder.buffer:
            key = id(ev.data["dispatcher"]), str(ev.data["args"])
            if ev.is_start:
                starts[key] = ts
            else:
                py = ev.data["dispatcher"].py_func
                rows.append((ts - starts[key], f"{py.__module__}.{py.__qualname__}"))
        print(f"{name}: {time.perf_counter() - t0:.2f} s, {len(rows)} compilations")
        for seconds, function in sorted(rows, reverse=True):
            print(f"  {seconds:6.2f} s  {function}")


if __name__ == "__main__":
    main(sys.argv[1])
