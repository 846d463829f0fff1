"""OMPL's RRT-Connect on a 2-D guard scene, for ``rtctl bench guard`` (run in its own process:
the optional ``ompl`` wheel stays out of rtctl's, and its exit-time noise with it).

Reads JSON on stdin — the scene's half-plane tables, the plane's joints, bounds, start, goal,
margin, runs — and writes one JSON line: per run the solve time, the time with OMPL's path
simplification, and the simplified path's length. The state validity checker is the guard's
own compiled depth test (the same free space the visibility graph plans in).
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np


def main() -> int:
    job = json.load(sys.stdin)
    from ompl import base as ob, geometric as og, util as ou

    from rtctl.guard.kernels import clearance

    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    rows, cols, pieces = (np.array(job[k], dtype=float if k == "rows" else np.int64) for k in ("rows", "cols", "pieces"))
    template = np.array(job["template"], float)
    i, j = job["plane"]
    margin = job["margin"]

    def valid(state) -> bool:
        template[i], template[j] = state[0], state[1]
        return clearance(rows, cols, pieces, template)[0] >= margin

    space = ob.RealVectorStateSpace(2)
    bounds = ob.RealVectorBounds(2)
    for d in range(2):
        bounds.setLow(d, job["lo"][d])
        bounds.setHigh(d, job["hi"][d])
    space.setBounds(bounds)
    runs = []
    for _ in range(job["runs"]):
        setup = og.SimpleSetup(space)
        setup.setStateValidityChecker(valid)
        info = setup.getSpaceInformation()
        info.setStateValidityCheckingResolution(job["resolution"])
        start, goal = space.allocState(), space.allocState()
        for d in range(2):
            start[d], goal[d] = job["start"][d], job["goal"][d]
        setup.setStartAndGoalStates(start, goal)
        setup.setPlanner(og.RRTConnect(info))
        t0 = time.perf_counter()
        solved = setup.solve(job["timeout"])
        t1 = time.perf_counter()
        if not setup.haveExactSolutionPath():
            runs.append({"solved": False, "solve_ms": (t1 - t0) * 1e3})
            continue
        setup.simplifySolution()
        t2 = time.perf_counter()
        path = setup.getSolutionPath()
        runs.append({"solved": bool(solved), "solve_ms": (t1 - t0) * 1e3, "with_simplify_ms": (t2 - t0) * 1e3,
                     "length": float(path.length()), "states": int(path.getStateCount())})
    print(json.dumps({"runs": runs}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
