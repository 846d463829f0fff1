"""The model-API fuzzer's child process (run by test_fuzz_model_api.py, never by pytest itself):
random shapes, dtypes, layouts and values into every public kinematics and dynamics function.

Each call must raise ValueError, TypeError or an rtctl error — or return, and when every
argument was a finite array of sensible size the result must be finite. The name of each call
is printed before it is made, so if this process dies (a segfault) the parent names the call.
Usage: ``python -X faulthandler model_api_fuzz_child.py EXAMPLES``.
"""
from __future__ import annotations

import json
import signal
import sys
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st
from hypothesis.extra import numpy as hnp

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "model"))

from random_robots import make_random_chain  # noqa: E402
from rtctl.errors import RtctlError  # noqa: E402
from rtctl.model import dynamics as dyn, kinematics as kin, load_robot  # noqa: E402

EXAMPLES = int(sys.argv[1]) if len(sys.argv) > 1 else 30
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, database=None,
                    suppress_health_check=list(HealthCheck))
SENSIBLE = 1e3  # inputs within ±SENSIBLE must give finite outputs

PUMA = load_robot(ROOT / "configs" / "robots" / "puma560.toml")
ROBOTS = [PUMA, load_robot(ROOT / "configs" / "robots" / "two_link.toml"), make_random_chain(7, seed=11)]


def on_alarm(signum, frame):
    raise TimeoutError("a model-API call ran longer than 10 s")


signal.signal(signal.SIGALRM, on_alarm)


class Sensible:
    """Whether every argument drawn so far was a finite, bounded float array or number."""

    def __init__(self):
        self.ok = True

    def note(self, x):
        try:
            a = np.asarray(x)
            self.ok &= a.dtype.kind in "iuf" and a.size > 0 and bool(np.all(np.abs(a) <= SENSIBLE))
        except Exception:
            self.ok = False
        return x


def anything_like(shape):
    """Mostly the right float64 array, sometimes anything else an API user might pass."""
    n = shape[0] if shape else 1
    good = hnp.arrays(np.float64, shape, elements=st.floats(-SENSIBLE, SENSIBLE))
    wild_shapes = st.sampled_from([(), (0,), (max(n - 1, 1),), (n + 1,), (206,), (1, *shape), (*shape, 1), (n, n)])
    wild = st.one_of(
        hnp.arrays(np.float64, shape, elements=st.floats(allow_nan=True, allow_infinity=True)),
        hnp.arrays(st.sampled_from([np.float32, np.int64, np.int8, np.uint8, np.bool_, np.complex128]), shape),
        wild_shapes.flatmap(lambda s: hnp.arrays(np.float64, s, elements=st.floats(-1.0, 1.0))),
        st.none(), st.floats(), st.integers(-10, 10), st.text(max_size=3),
        st.lists(st.floats(-1, 1), max_size=9), st.just([[0.0] * n, [0.0]]),  # ragged
        st.just(np.array(["ab"] * n)), st.just(np.array([None] * n, dtype=object)),
        hnp.arrays(np.float64, (2 * n, *shape[1:]), elements=st.floats(-1, 1)).map(lambda a: a[::2]),  # strided
    )
    return st.one_of(good, good, good, wild)


def outputs(shape):
    """A preallocated output for a *_into: mostly right, sometimes the wrong size, dtype, layout or read-only."""
    n = shape[0]

    def read_only(a):
        a.setflags(write=False)
        return a

    return st.one_of(
        st.just(shape).map(np.zeros), st.just(shape).map(np.zeros),
        st.sampled_from([(n + 1,) * len(shape), (max(n - 1, 1),) * len(shape), (200,) * len(shape), (n, n, 1)])
        .map(np.zeros),
        st.just(shape).map(lambda s: np.zeros(s, np.float32)),
        st.just(shape).map(lambda s: np.zeros(s)).map(read_only),
        st.just((2 * n, *shape[1:])).map(lambda s: np.zeros(s)[::2]),
        st.none(),
    )


def call(name, fn, sensible: Sensible):
    print(json.dumps({"calling": name}), flush=True)
    signal.alarm(10)
    try:
        result = fn()
    except (ValueError, TypeError, RtctlError):
        return
    finally:
        signal.alarm(0)
    if sensible.ok:
        values = result if isinstance(result, tuple) else (result,)
        for v in values:
            if isinstance(v, np.ndarray) or isinstance(v, float):
                assert np.all(np.isfinite(v)), (name, "non-finite result for sensible input", v)


robots = st.sampled_from(range(len(ROBOTS)))


CONVENIENCE = ("fk", "link_poses", "jacobian", "tool_twist", "joint_rates", "gravity", "mass_matrix", "rnea",
               "coriolis_matrix", "mass_matrix_dot", "forward_dynamics", "regressor", "slotine_li_regressor")
INTO = ("rnea_into", "gravity_into", "bias_into", "mass_matrix_into", "coriolis_matrix_into", "forward_dynamics_into")
POSES = ("to_oat", "from_oat", "ik", "ik_solutions", "configuration")


@SETTINGS
@given(data=st.data(), r=robots)
def fuzz_convenience(name, data, r):
    m, s = ROBOTS[r], Sensible()
    n = m.nq

    def vec():
        return s.note(data.draw(anything_like((n,))))

    calls = {
        "fk": lambda: kin.fk(m, vec()),
        "link_poses": lambda: kin.link_poses(m, vec()),
        "jacobian": lambda: kin.jacobian(m, vec()),
        "tool_twist": lambda: kin.tool_twist(m, vec(), vec()),
        "joint_rates": lambda: kin.joint_rates(m, vec(), s.note(data.draw(anything_like((6,))))),
        "gravity": lambda: dyn.gravity(m, vec()),
        "mass_matrix": lambda: dyn.mass_matrix(m, vec()),
        "rnea": lambda: dyn.rnea(m, vec(), vec(), vec()),
        "coriolis_matrix": lambda: dyn.coriolis_matrix(m, vec(), vec(), data.draw(st.sampled_from(
            ["christoffel", "cstar", "classic", 3]))),
        "mass_matrix_dot": lambda: dyn.mass_matrix_dot(m, vec(), vec()),
        "forward_dynamics": lambda: dyn.forward_dynamics(m, vec(), vec(), vec(), data.draw(st.one_of(
            st.none(), hnp.arrays(np.float64, (n,), elements=st.floats(0, 1)), anything_like((n,))))),
        "regressor": lambda: dyn.regressor(m, vec(), vec(), vec()),
        "slotine_li_regressor": lambda: dyn.slotine_li_regressor(m, vec(), vec(), vec(), vec()),
    }
    fn = calls[name]
    call(f"{name}({m.name})", fn, s)


@SETTINGS
@given(data=st.data(), r=robots, r_data=robots)
def fuzz_into(name, data, r, r_data):
    m, s = ROBOTS[r], Sensible()
    n = m.nq
    arrays = dyn.model_arrays(m)
    if data.draw(st.booleans()):  # estimates of the wrong shape or dtype
        arrays = arrays._replace(params=data.draw(st.sampled_from(
            [np.zeros((n, 10)), np.zeros((n + 1, 10)), np.zeros((n, 9)), np.zeros((n, 10), np.float32)])))
    d = dyn.Data(ROBOTS[r_data])  # sometimes another robot's workspace

    def vec():
        return s.note(data.draw(anything_like((n,))))

    fn = {
        "rnea_into": lambda: dyn.rnea_into(arrays, d, vec(), vec(), vec(), data.draw(outputs((n,)))),
        "gravity_into": lambda: dyn.gravity_into(arrays, d, vec(), data.draw(outputs((n,)))),
        "bias_into": lambda: dyn.bias_into(arrays, d, vec(), vec(), data.draw(outputs((n,)))),
        "mass_matrix_into": lambda: dyn.mass_matrix_into(arrays, d, vec(), data.draw(outputs((n, n)))),
        "coriolis_matrix_into": lambda: dyn.coriolis_matrix_into(
            arrays, d, vec(), vec(), data.draw(st.sampled_from([dyn.CHRISTOFFEL, dyn.CSTAR, 2, -1])),
            data.draw(outputs((n, n)))),
        "forward_dynamics_into": lambda: dyn.forward_dynamics_into(
            arrays, d, vec(), vec(), vec(), data.draw(st.one_of(st.just(np.zeros(n)), anything_like((n,)))),
            data.draw(outputs((n,)))),
    }[name]
    s.ok = False  # the *_into forms check shapes and dtypes, not values: no finiteness asked
    call(f"{name}({m.name}, data of {ROBOTS[r_data].name})", fn, s)


@SETTINGS
@given(data=st.data())
def fuzz_poses(name, data):
    s = Sensible()
    pose = s.note(data.draw(anything_like((4, 4))))
    fn = {
        "to_oat": lambda: kin.to_oat(pose),
        "from_oat": lambda: kin.from_oat(*(s.note(data.draw(st.one_of(st.floats(-3, 3), st.floats(), st.none())))
                                           for _ in range(3))),
        "ik": lambda: kin.ik(PUMA, pose, data.draw(st.one_of(st.none(), anything_like((6,))))),
        "ik_solutions": lambda: kin.ik_solutions(PUMA, pose),
        "configuration": lambda: kin.configuration(PUMA, s.note(data.draw(anything_like((6,))))),
    }[name]
    if name in ("ik", "ik_solutions", "configuration", "to_oat"):
        s.ok = False  # a random 4×4 is no pose: only "a clear error or a return" is asked
    call(name, lambda: fn(), s)


def warm_up():
    """Compile (or load) every kernel once, outside the time limit of a call."""
    for m in ROBOTS:
        z = np.zeros(m.nq)
        kin.joint_rates(m, z, np.zeros(6))
        for kind in ("christoffel", "cstar"):
            dyn.coriolis_matrix(m, z, z, kind)
        dyn.mass_matrix_dot(m, z, z)
        dyn.forward_dynamics(m, z, z, z, np.ones(m.nq))
        dyn.rnea(m, z, z, z)
        dyn.mass_matrix(m, z)


if __name__ == "__main__":  # every function, EXAMPLES random calls each
    warm_up()
    for fuzz, names in ((fuzz_convenience, CONVENIENCE), (fuzz_into, INTO), (fuzz_poses, POSES)):
        for name in names:
            fuzz(name=name)
    print(json.dumps({"done": True}), flush=True)
