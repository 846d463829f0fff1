"""Switching controllers at run time (rtctl.switching): which switches are refused, and the
bumpless blend against its closed form."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rtctl.errors import ConfigError, RtctlError
from rtctl.switching import BLEND_TIME_S, Blend, plan_switch

NAMES = ("a", "b", "c", "d")


def controller(name, joints, divisor=1):
    n = len(NAMES)
    mask = np.zeros(n, dtype=bool)
    mask[list(joints)] = True
    return SimpleNamespace(name=name, joints=np.array(joints, dtype=np.int64), mask=mask, divisor=divisor,
                           model=SimpleNamespace(joint_names=NAMES))


ARM = controller("arm", [0, 1, 2])
WRIST = controller("wrist", [3])
ADAPTIVE = controller("adaptive", [0, 1, 2])
WHOLE = controller("whole", [0, 1, 2, 3])
CONFIGURED = [ARM, WRIST, ADAPTIVE, WHOLE]


def test_a_switch_that_moves_joints_from_one_controller_to_another_is_planned_in_the_configuration_order():
    assert plan_switch(CONFIGURED, [ARM, WRIST], ["adaptive"], ["arm"]) == [WRIST, ADAPTIVE]
    assert plan_switch(CONFIGURED, [ARM, WRIST], ["whole"], ["arm", "wrist"]) == [WHOLE]
    assert plan_switch(CONFIGURED, [WHOLE], ["arm", "wrist"], ["whole"]) == [ARM, WRIST]


@pytest.mark.parametrize("activate, deactivate, says", [
    (["adaptive"], [], "joint 'a' would have two controllers, 'arm' and 'adaptive'"),
    ([], ["wrist"], "joint 'd' would have no controller ('wrist' is deactivated"),
    (["adaptive"], ["arm", "wrist"], "joint 'd' would have no controller"),
    (["whole"], ["arm"], "joint 'd' would have two controllers"),
    (["nosuch"], ["arm"], "no controller 'nosuch' (configured: arm, wrist, adaptive, whole)"),
    (["arm"], ["arm"], "'arm' is both activated and deactivated"),
])
def test_a_switch_that_leaves_a_joint_without_a_controller_or_gives_it_two_is_refused_with_the_reason(
        activate, deactivate, says):
    with pytest.raises(RtctlError, match="switch refused") as e:
        plan_switch(CONFIGURED, [ARM, WRIST], activate, deactivate)
    assert says in str(e.value)


def test_the_blended_command_is_continuous_at_the_switch_and_decays_to_the_new_controllers_own_torque():
    """τ_k = τ_new,k + (τ_old − τ_new,0) e^{−k Δt / T} (closed form), on the switched joints only."""
    dt, n = 1e-3, 4
    blend = Blend(n, dt)
    tau_old = np.array([5.0, -3.0, 2.0, 7.0])
    blend.begin(tau_old, [ARM])
    rng = np.random.default_rng(1)
    new = rng.normal(size=(blend.ticks + 5, n)) * 10  # the new controller's own torques, tick by tick
    tau = tau_old.copy()
    for k in range(blend.ticks + 5):
        tau[:3] = new[k, :3]  # the new controller writes its joints; joint 3 keeps its own command
        if blend.active:
            blend.apply(tau, lambda divisor: True)
        if k < blend.ticks - 1:
            expected = new[k, :3] + (tau_old[:3] - new[0, :3]) * math.exp(-k * dt / BLEND_TIME_S)
            np.testing.assert_allclose(tau[:3], expected, rtol=1e-12, atol=1e-12)
        else:  # the blend has ended (its last tick included): the controller's own torque
            np.testing.assert_array_equal(tau[:3], new[k, :3])
        assert tau[3] == 7.0
    assert blend.ticks * dt == pytest.approx(8 * BLEND_TIME_S, abs=dt)


def test_a_controller_that_runs_every_few_ticks_is_blended_from_the_torque_it_holds_not_accumulated():
    """Between its updates the command holds the last blended value; the blend must start again
    from the controller's own held torque, not add the offset to an already blended command."""
    dt = 1e-3
    slow = controller("slow", [0], divisor=20)
    blend = Blend(4, dt)
    blend.begin(np.array([10.0, 0, 0, 0]), [slow])
    tau = np.zeros(4)
    for k in range(200):
        if k % 20 == 0:
            tau[0] = 4.0  # its update: the same torque each time
        blend.apply(tau, lambda divisor, k=k: k % divisor == 0)
        assert tau[0] == pytest.approx(4.0 + 6.0 * math.exp(-k * dt / BLEND_TIME_S), rel=1e-12)


def test_a_controller_started_between_its_updates_is_blended_from_its_first_update():
    """The tick updates a controller at the tick after its switch whatever its divisor: its first
    torque is the one the offset is taken against (not the old controller's left in the command)."""
    dt = 1e-3
    slow = controller("slow", [0], divisor=20)
    blend = Blend(4, dt)
    blend.begin(np.array([10.0, 0, 0, 0]), [slow])
    tau = np.array([10.0, 0, 0, 0])
    tau[0] = 4.0  # the forced first update (tick 7 of its 20: not due)
    blend.apply(tau, lambda divisor: False)
    assert tau[0] == 10.0
    blend.apply(tau, lambda divisor: False)  # held, not updated
    assert tau[0] == pytest.approx(4.0 + 6.0 * math.exp(-dt / BLEND_TIME_S), rel=1e-12)


SWITCHABLE = """
[[controllers]]
name = "adaptive"
type = "slotine_li"
active = false
lam = 10.0
kd = 40.0
gamma = 1.0
"""


def test_inactive_controllers_may_share_joints_with_active_ones(write_config):
    from rtctl.config import load_config
    from runtime_helpers import BASE

    text = BASE.replace("[trajectory]", SWITCHABLE + "\n[trajectory]")
    cfg = load_config(write_config(text))
    assert [(c.name, c.active) for c in cfg.controllers] == [("ct", True), ("adaptive", False)]


@pytest.mark.parametrize("change, key, says", [
    (("active = false\n", "active = true\n"), "controllers[1].joints", "one controller per joint (among the active ones)"),
    (('name = "adaptive"', 'name = "ct"'), "controllers[1].name", "'ct' is taken"),
    (("active = false\n", "active = false\njoints = []\n"), None, None),
    (("active = false\n", "active = 0\n"), "controllers[1].active", "true or false"),
])
def test_controller_activity_errors_name_the_key(write_config, change, key, says):
    from rtctl.config import load_config
    from runtime_helpers import BASE

    text = BASE.replace("[trajectory]", SWITCHABLE.replace(*change) + "\n[trajectory]")
    if key is None:
        load_config(write_config(text))  # an inactive observer: nothing to take over, accepted
        return
    with pytest.raises(ConfigError) as e:
        load_config(write_config(text))
    assert e.value.key_path == key and says in e.value.expected


def test_an_inactive_controller_may_only_take_over_joints_an_active_one_owns(write_config):
    from rtctl.config import load_config
    from runtime_helpers import BASE

    text = BASE.replace('[[controllers]]\nname = "ct"\ntype = "computed_torque"\n',
                        '[[controllers]]\nname = "ct"\ntype = "computed_torque"\njoints = ["waist", "shoulder", "elbow"]\n')
    text = text.replace("[trajectory]", SWITCHABLE + "\n[trajectory]")
    with pytest.raises(ConfigError) as e:
        load_config(write_config(text))
    assert e.value.key_path == "controllers[1].joints" and "joint 3 has no active owner" in e.value.expected


def test_the_blend_allocates_nothing_per_tick():
    from allocations import growth_and_peak

    slow, fast = controller("slow", [0], divisor=20), controller("fast", [1, 2])
    blend = Blend(4, 1e-3, time_constant=10.0)  # long enough to stay active for the whole measurement
    tau = np.ones(4)
    due = (lambda divisor: True)
    blend.begin(tau, [slow, fast])
    for _ in range(50):
        blend.apply(tau, due)
    growth, peak = growth_and_peak(lambda: blend.apply(tau, due), 2000)
    assert blend.active
    assert growth <= 64 and peak < 1024, (growth, peak)
