"""The Slotine–Li controller's options and its side-effect-free ``compute``, the cases a run of
every rtctl/control mutant found unchecked (docs/mutation/control.md):

* ``gamma`` by parameter class fills the 10 columns in Pinocchio's order (m | h_x h_y h_z |
  J_xx … J_zz): mass 1 column, first moment 3, inertia 6;
* ``adaptation_gains``: n numbers are one gain per link for all 10 parameters; a negative gain
  is refused (−0.5 too), as is a non-finite one;
* ``initial_params``: "true" is the model's parameters themselves, "scaled" without a scale
  is too;
* a configuration without ``dead_zone`` has none (default 0, documented), "scaled" without a
  scale (in a configuration or the constructor) is the model's parameters;
* ``compute`` changes no state: with the projection on and an inconsistent π̂, π̂ stays as it
  was (the projection runs only with an integration step);
* a bad ``gamma`` and a bad ``params0`` file each name their own key (the restarted full run).
"""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.config import load_config
from rtctl.control.slotine_li import SlotineLi, adaptation_gains, initial_params
from rtctl.runtime import build
from test_config import configured


def test_gamma_by_class_fills_the_columns_in_pinocchios_order(tmp_path):
    path = configured(tmp_path, "")
    text = path.read_text().replace("gamma = 1.0\n", "gamma = { mass = 1.0, first_moment = 2.0, inertia = 3.0 }\n", 1)
    path.write_text(text)
    (c,) = build(load_config(path)).controllers
    assert c.gamma.tolist() == [[1.0, 2.0, 2.0, 2.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0]] * 6


def test_one_gain_per_link_covers_its_ten_parameters():
    g = adaptation_gains([1.0, 2.0, 3.0], 3)
    assert g.tolist() == [[1.0] * 10, [2.0] * 10, [3.0] * 10]


@pytest.mark.parametrize("gamma", [-0.5, [1.0, -0.5, 1.0], np.inf, [1.0, np.nan, 1.0]])
def test_a_negative_or_non_finite_gain_is_refused(gamma):
    with pytest.raises(ValueError, match="all ≥ 0"):
        adaptation_gains(gamma, 3)


def test_true_and_unscaled_initial_estimates_are_the_models_parameters(puma):
    np.testing.assert_array_equal(initial_params(puma, "true"), puma.params)
    np.testing.assert_array_equal(initial_params(puma, "scaled"), puma.params)
    np.testing.assert_array_equal(initial_params(puma, "scaled", 0.5), 0.5 * puma.params)


def test_compute_leaves_an_inconsistent_estimate_alone_even_with_the_projection_on(puma):
    c = SlotineLi(puma, lam=10.0, kd=50.0, gamma=1.0, projection=True)
    c.params_hat[0, 0] = -1.0  # a negative mass: outside the consistent set
    before = c.params_hat.copy()
    n = puma.nq
    c.compute(np.full(n, 0.2), np.full(n, 0.1), np.zeros(n), np.zeros(n), np.zeros(n))
    np.testing.assert_array_equal(c.params_hat, before)


def test_a_configuration_without_a_dead_zone_or_a_scale_has_neither(tmp_path):
    """`dead_zone` defaults to 0 (docs/cstar_slotine_li.md); "scaled" without `params_scale`
    is the model's parameters."""
    (c,) = build(load_config(configured(tmp_path, 'params0 = "scaled"\n'))).controllers
    assert c.dead_zone == 0.0
    np.testing.assert_array_equal(c.params0, c.model.params)


def test_the_constructors_scaled_estimate_without_a_scale_is_the_models(puma):
    np.testing.assert_array_equal(SlotineLi(puma, lam=10.0, kd=50.0, gamma=1.0, params0="scaled").params0, puma.params)


@pytest.mark.parametrize("options, key", [
    ("", "gamma"),  # gamma = −0.5, refused by adaptation_gains: named as gamma
    ('params0 = "estimates.npy"\n', "params0"),  # a file of the wrong shape
])
def test_a_bad_gamma_or_initial_estimate_file_names_its_own_key(tmp_path, options, key):
    from rtctl.errors import ConfigError

    path = configured(tmp_path, options)
    if key == "gamma":
        path.write_text(path.read_text().replace("gamma = 1.0\n", "gamma = -0.5\n", 1))
    np.save(tmp_path / "estimates.npy", np.zeros(7))
    with pytest.raises(ConfigError) as e:
        build(load_config(path))
    assert e.value.key_path.endswith(key)
