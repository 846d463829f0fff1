"""Properties of the dynamics that need no reference implementation (docs/cstar_slotine_li.md): the paper's
Propositions 1 and 2, C* q̇ = C q̇ = RNEA(q, q̇, 0) − G, Y π for both regressors, Ḣ against finite
differences, the two-link arm's published closed form, and the hot-path forms."""
import numpy as np
import pytest
from numba import njit
from numba.core.runtime import _nrt_python, rtsys

from rtctl.model import dynamics as dyn
from rtctl.model.coriolis import CSTAR, coriolis_kernel
from rtctl.model.crba import crba_kernel
from rtctl.model.dynamics import Data, model_arrays
from rtctl.model.forward_dynamics import forward_dynamics_kernel
from rtctl.model.rnea import rnea_kernel

KINDS = ("christoffel", "cstar")


@pytest.fixture(params=["puma", "two_link", "random3", "random6", "random9"])
def model(request):
    name = request.param
    if name.startswith("random"):
        n = int(name[6:])
        return request.getfixturevalue("random_chain")(n, seed=200 + n)
    return request.getfixturevalue(name)


def hdot_fd(model, q, qd, h=1e-4):
    """Ḣ = dH/dt along q̇ by a fourth-order central difference."""
    H = lambda t: dyn.mass_matrix(model, q + t * qd)  # noqa: E731
    return (-H(2 * h) + 8 * H(h) - 8 * H(-h) + H(-2 * h)) / (12 * h)


def test_proposition_2_both_factorisations(model, states):
    for q, qd, _ in states(model, 40, seed=5):
        Hd = hdot_fd(model, q, qd)
        scale = 1e-9 * max(1.0, np.linalg.norm(dyn.mass_matrix(model, q)))
        np.testing.assert_allclose(dyn.mass_matrix_dot(model, q, qd), Hd, atol=scale)
        for kind in KINDS:
            C = dyn.coriolis_matrix(model, q, qd, kind)
            N = Hd - 2 * C
            assert np.linalg.norm(N + N.T) <= scale, kind  # Ḣ − 2C skew ⇔ Ḣ = C + Cᵀ


def test_coriolis_times_velocity_is_the_velocity_product(model, states):
    for q, qd, _ in states(model, 100, seed=6):
        expected = dyn.rnea(model, q, qd, np.zeros(model.nq)) - dyn.gravity(model, q)
        for kind in KINDS:
            np.testing.assert_allclose(dyn.coriolis_matrix(model, q, qd, kind) @ qd, expected, atol=1e-9)


@pytest.mark.parametrize("n", [3, 4, 6, 9])
def test_proposition_1_cstar_differs_from_christoffel_for_three_or_more_joints(n, random_chain, states):
    model = random_chain(n, seed=300 + n, prismatic=False)
    for q, qd, _ in states(model, 20, seed=7):
        C, Cs = (dyn.coriolis_matrix(model, q, qd, kind) for kind in KINDS)
        assert np.linalg.norm(Cs - C) > 1e-6 * np.linalg.norm(C)


def test_proposition_1_also_on_the_puma(puma, states):
    for q, qd, _ in states(puma, 20, seed=8):
        C, Cs = (dyn.coriolis_matrix(puma, q, qd, kind) for kind in KINDS)
        assert np.linalg.norm(Cs - C) > 1e-6 * np.linalg.norm(C)


@pytest.mark.parametrize("n", [1, 2])
def test_proposition_1_they_coincide_for_one_or_two_joints(n, random_chain, two_link, states):
    for model in (random_chain(n, seed=400 + n), two_link):
        for q, qd, _ in states(model, 50, seed=9):
            C, Cs = (dyn.coriolis_matrix(model, q, qd, kind) for kind in KINDS)
            np.testing.assert_allclose(Cs, C, atol=1e-12)


def test_regressors_reproduce_their_factorisations(model, states):
    pi = model.params.ravel()
    rng = np.random.default_rng(10)
    for q, qd, qdd in states(model, 50, seed=10):
        np.testing.assert_allclose(dyn.regressor(model, q, qd, qdd) @ pi, dyn.rnea(model, q, qd, qdd), atol=1e-9)
        qdr, qddr = rng.uniform(-2, 2, model.nq), rng.uniform(-5, 5, model.nq)
        H, G = dyn.mass_matrix(model, q), dyn.gravity(model, q)
        for kind in KINDS:
            C = dyn.coriolis_matrix(model, q, qd, kind)
            Y = dyn.slotine_li_regressor(model, q, qd, qdr, qddr, kind)
            np.testing.assert_allclose(Y @ pi, H @ qddr + C @ qdr + G, atol=1e-9, err_msg=kind)


def test_two_link_matches_slotine_and_li_closed_form(two_link, states):
    """Applied Nonlinear Control, Example 9.2: H from a1…a4, C from h = a3 sin q2 − a4 cos q2."""
    m1, l1, me, de, I1, lc1, Ie, lce = 1.0, 1.0, 2.0, np.radians(30), 0.12, 0.5, 0.25, 0.6
    a1 = I1 + m1 * lc1**2 + Ie + me * lce**2 + me * l1**2
    a2 = Ie + me * lce**2
    a3, a4 = me * l1 * lce * np.cos(de), me * l1 * lce * np.sin(de)
    for q, qd, _ in states(two_link, 50, seed=11):
        c2, s2 = np.cos(q[1]), np.sin(q[1])
        H = np.array([[a1 + 2 * a3 * c2 + 2 * a4 * s2, a2 + a3 * c2 + a4 * s2], [a2 + a3 * c2 + a4 * s2, a2]])
        h = a3 * s2 - a4 * c2
        C = np.array([[-h * qd[1], -h * (qd[0] + qd[1])], [h * qd[0], 0.0]])
        np.testing.assert_allclose(dyn.mass_matrix(two_link, q), H, atol=1e-12)
        np.testing.assert_allclose(dyn.coriolis_matrix(two_link, q, qd), C, atol=1e-12)
        np.testing.assert_allclose(dyn.gravity(two_link, q), 0.0, atol=1e-12)  # horizontal plane


def test_forward_dynamics_inverts_rnea(model, states):
    armature = np.full(model.nq, 0.1)
    for q, qd, qdd in states(model, 50, seed=12):
        tau = dyn.rnea(model, q, qd, qdd) + armature * qdd
        np.testing.assert_allclose(dyn.forward_dynamics(model, q, qd, tau, armature), qdd, atol=1e-8)


def test_hot_path_matches_convenience_api(puma, states):
    arrays, data = model_arrays(puma), Data(puma)
    n = puma.nq
    tau, g, b, qdd_out, H, C = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros((n, n)), np.zeros((n, n))
    armature = np.full(n, 0.2)
    for q, qd, qdd in states(puma, 5, seed=13):
        dyn.rnea_into(arrays, data, q, qd, qdd, tau)
        dyn.gravity_into(arrays, data, q, g)
        dyn.bias_into(arrays, data, q, qd, b)
        dyn.mass_matrix_into(arrays, data, q, H)
        dyn.forward_dynamics_into(arrays, data, q, qd, tau + armature * qdd, armature, qdd_out)
        dyn.coriolis_matrix_into(arrays, data, q, qd, dyn.CSTAR, C)
        np.testing.assert_allclose(tau, dyn.rnea(puma, q, qd, qdd), atol=1e-12)
        np.testing.assert_allclose(g, dyn.gravity(puma, q), atol=1e-12)
        np.testing.assert_allclose(b, dyn.rnea(puma, q, qd, np.zeros(n)), atol=1e-12)
        np.testing.assert_allclose(H, dyn.mass_matrix(puma, q), atol=1e-12)
        np.testing.assert_allclose(qdd_out, qdd, atol=1e-9)
        np.testing.assert_allclose(C, dyn.coriolis_matrix(puma, q, qd, "cstar"), atol=1e-12)


@njit
def _touch(*arrays):
    return None


def test_kernels_allocate_nothing_beyond_their_arguments(puma):
    """Numba counts one NRT allocation per array argument it unboxes; a kernel must add none."""
    a, d, n = model_arrays(puma), Data(puma), puma.nq
    q, tau, H = np.full(n, 0.3), np.zeros(n), np.zeros((n, n))
    calls = [
        (rnea_kernel, (*a, d.X, d.body, q, q, q, tau)),
        (crba_kernel, (a.joint, a.geom, a.params, d.X, d.body, d.Ic, q, H)),
        (forward_dynamics_kernel, (*a, d.X, d.body, d.Ic, d.H, q, q, q, q, tau)),
        (coriolis_kernel, (a.joint, a.geom, a.params, d.X, d.body, d.I6, d.B6, d.M6, q, q, CSTAR, H)),
    ]
    _nrt_python.memsys_enable_stats()
    try:
        for kernel, args in calls:
            counts = []
            for fn in (kernel, _touch):
                fn(*args)  # compile or load from cache
                before = rtsys.get_allocation_stats().alloc
                fn(*args)
                counts.append(rtsys.get_allocation_stats().alloc - before)
            assert counts[0] == counts[1], kernel
    finally:
        _nrt_python.memsys_disable_stats()


def test_estimated_parameters_through_replace(puma, states):
    params = puma.params * 1.3
    arrays = model_arrays(puma)._replace(params=params)
    tau = np.zeros(puma.nq)
    for q, qd, qdd in states(puma, 5, seed=14):
        dyn.rnea_into(arrays, Data(puma), q, qd, qdd, tau)
        np.testing.assert_allclose(tau, dyn.rnea(puma.with_params(params), q, qd, qdd), atol=1e-12)


def test_bad_arguments_are_refused(puma):
    with pytest.raises(ValueError, match="6 joint values"):
        dyn.rnea(puma, np.zeros(5), np.zeros(6), np.zeros(6))
    with pytest.raises(ValueError, match="kind"):
        dyn.coriolis_matrix(puma, np.zeros(6), np.zeros(6), "classic")
    with pytest.raises(ValueError, match="kind"):
        dyn.slotine_li_regressor(puma, *np.zeros((4, 6)), kind="nope")
