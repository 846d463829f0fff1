"""Property tests of the spatial-algebra identities (Featherstone 2008, ch. 2)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rtctl.compiled import kernel
from rtctl.model import PRISMATIC, REVOLUTE
from rtctl.model import spatial_kernels as sk
from rtctl.model.data import BODY_SLOTS, SUB
from rtctl.model.dh import inertial_params
from rtctl.model.recursions import update_joints
from rtctl.model.rotations import rot_axis, skew
from rtctl.model.spatial import (
    crf, crm, force_transform, icrf, inertia, inertia_basis, inertia_params, inertia_regressor,
    jcalc, mcI, plucker, plucker_inv, rot, xlt,
)

finite = st.floats(-3, 3, allow_nan=False, allow_infinity=False)
vec6 = arrays(np.float64, 6, elements=finite)
vec3 = arrays(np.float64, 3, elements=finite)
params10 = arrays(np.float64, 10, elements=finite)
TOL = 1e-10
settings.register_profile("model", max_examples=60, deadline=None)
settings.load_profile("model")


@st.composite
def transforms(draw):
    axis = draw(vec3)
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([0.0, 0.0, 1.0])
    R = rot_axis(axis / np.linalg.norm(axis), draw(finite))
    return plucker(R, draw(vec3))


@given(vec6, vec6)
def test_crm_is_the_motion_cross_product(v, m):
    w, u = v[:3], v[3:]
    expected = np.concatenate([np.cross(w, m[:3]), np.cross(w, m[3:]) + np.cross(u, m[:3])])
    np.testing.assert_allclose(crm(v) @ m, expected, atol=TOL)


@given(vec6, vec6)
def test_crf_is_minus_crm_transposed_and_the_force_cross_product(v, f):
    np.testing.assert_array_equal(crf(v), -crm(v).T)
    w, u = v[:3], v[3:]
    expected = np.concatenate([np.cross(w, f[:3]) + np.cross(u, f[3:]), np.cross(w, f[3:])])
    np.testing.assert_allclose(crf(v) @ f, expected, atol=TOL)
    # power is invariant: (v × m)·f + m·(v ×* f) = 0
    m = np.roll(f, 2)
    assert abs((crm(v) @ m) @ f + m @ (crf(v) @ f)) < 1e-9


@given(vec6, vec6)
def test_icrf_swaps_the_arguments_of_crf(v, f):
    np.testing.assert_allclose(icrf(f) @ v, crf(v) @ f, atol=TOL)


@given(transforms())
def test_force_transform_is_inverse_transpose(X):
    np.testing.assert_allclose(force_transform(X), np.linalg.inv(X).T, atol=TOL)
    np.testing.assert_allclose(plucker_inv(X) @ X, np.eye(6), atol=TOL)


@given(transforms(), vec6)
def test_cross_products_transform_covariantly(X, v):
    Xi = plucker_inv(X)
    np.testing.assert_allclose(crm(X @ v), X @ crm(v) @ Xi, atol=1e-9)
    np.testing.assert_allclose(crf(X @ v), force_transform(X) @ crf(v) @ X.T, atol=1e-9)


@given(transforms(), transforms())
def test_plucker_composes_like_the_frames_it_describes(X1, X2):
    # placements compose: ᶜX_A = ᶜX_B ᴮX_A matches the 4×4 product of the frames
    R1, p1 = X1[:3, :3].T, -_unskew(X1[:3, :3].T @ X1[3:, :3])
    R2, p2 = X2[:3, :3].T, -_unskew(X2[:3, :3].T @ X2[3:, :3])
    np.testing.assert_allclose(plucker(R1, p1), X1, atol=TOL)
    np.testing.assert_allclose(X2 @ X1, plucker(R1 @ R2, p1 + R1 @ p2), atol=1e-9)


def _unskew(S):
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


@given(params10, params10, finite)
def test_inertia_is_linear_in_the_parameters_and_basis_matches(a, b, s):
    np.testing.assert_allclose(inertia(a + s * b), inertia(a) + s * inertia(b), atol=1e-9)
    np.testing.assert_allclose(np.einsum("kij,k->ij", inertia_basis(), a), inertia(a), atol=TOL)
    np.testing.assert_allclose(inertia_params(inertia(a)), a, atol=TOL)


@given(params10, vec6)
def test_inertia_regressor(p, x):
    np.testing.assert_allclose(inertia_regressor(x) @ p, inertia(p) @ x, atol=1e-9)


@given(st.floats(0.1, 5), vec3, arrays(np.float64, 3, elements=st.floats(0.01, 1)))
def test_mcI_equals_inertia_of_the_parameters(m, c, second):
    Ic = np.diag([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    np.testing.assert_allclose(mcI(m, c, Ic), inertia(inertial_params(m, c, Ic)), atol=1e-9)
    assert np.all(np.linalg.eigvalsh(mcI(m, c, Ic)) > 0)
    # kinetic energy of a point-mass model: ½ vᵀ I v for a pure translation is ½ m |v|²
    v = np.array([0, 0, 0, 1.0, 2.0, -1.0])
    assert abs(v @ mcI(m, c, Ic) @ v - m * 6.0) < 1e-9


@given(transforms(), params10)
def test_inertia_transforms_as_XT_I_X(X, p):
    # ᴬI = ᴮX_Aᵀ ᴮI ᴮX_A stays an inertia (the structure of eq. 17 is frame independent)
    IA = X.T @ inertia(p) @ X
    np.testing.assert_allclose(inertia(inertia_params(IA)), IA, atol=1e-8)


@given(vec3, finite, st.sampled_from([REVOLUTE, PRISMATIC]))
def test_jcalc(axis, q, jtype):
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([1.0, 0.0, 0.0])
    axis = axis / np.linalg.norm(axis)
    XJ, S = jcalc(jtype, axis, q)
    if jtype == REVOLUTE:
        np.testing.assert_allclose(S, np.r_[axis, 0, 0, 0])
        np.testing.assert_allclose(XJ, rot(rot_axis(axis, q)), atol=TOL)
        np.testing.assert_allclose(XJ @ S, S, atol=TOL)  # the axis is fixed by its own rotation
    else:
        np.testing.assert_allclose(S, np.r_[0, 0, 0, axis])
        np.testing.assert_allclose(XJ, xlt(axis * q), atol=TOL)
    # dX_J/dq = −crm(S) X_J (the joint velocity seen in the child frame)
    h = 1e-6
    dX = (jcalc(jtype, axis, q + h)[0] - jcalc(jtype, axis, q - h)[0]) / (2 * h)
    np.testing.assert_allclose(dX, -crm(S) @ XJ, atol=1e-7)


def test_skew_and_xlt_match_the_book():
    p = np.array([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(xlt(p)[3:, :3], -skew(p))


@kernel
def _leaves(Xs, V, P, results, dot):
    """Every spatial leaf once, compiled as the recursions compile them: inputs m = V[0, 0],
    f = V[0, 1]; results[k] as listed in the test."""
    sk.xmotion(Xs, 0, V, 0, 0, 1, 0)
    sk.xforce_T(Xs, 0, V, 0, 1, 1, 1, False)
    sk.xforce_T(Xs, 0, V, 0, 1, 1, 2, True)
    sk.crm_mul(V, 0, 0, 1, 2.0, 2, False)
    sk.crm_mul(V, 0, 0, 1, 2.0, 3, True)
    sk.crf_mul_add(V, 0, 0, 1, 4)
    sk.inertia_mul(P, 0, V, 0, 0, 5)
    sk.inertia_to_parent_add(Xs, 0, P, 0, 1)
    dot[0] = sk.dot6(V, 0, 0, 0, 1)
    for k in range(6):
        results[0, k], results[1, k], results[2, k] = V[1, 0, k], V[1, 1, k], V[1, 2, k]
        results[3, k], results[4, k], results[5, k], results[6, k] = V[0, 2, k], V[0, 3, k], V[0, 4, k], V[0, 5, k]


@given(transforms(), vec6, vec6, params10)
def test_compiled_kernels_match_the_6x6_forms(X, m, f, p):
    E = X[:3, :3]
    r = -_unskew(E.T @ X[3:, :3])
    Xs = np.zeros((1, 4, 3))  # the kernels' layout: X[i] = (E; r), vectors V[link, slot], parameters P[link]
    Xs[0, :3], Xs[0, 3] = E, r
    V = np.zeros((2, 6, 6))
    V[0, 0], V[0, 1] = m, f
    V[1, 2] = m  # xforce_T accumulates onto it
    V[0, 3] = f  # crm_mul accumulates onto it
    V[0, 4] = m  # crf_mul_add accumulates onto it
    P = np.zeros((2, 10))
    P[0] = p
    results, dot = np.zeros((7, 6)), np.zeros(1)
    _leaves(Xs, V, P, results, dot)
    for got, expected in zip(results, [X @ m, X.T @ f, m + X.T @ f, 2.0 * crm(m) @ f, f + 2.0 * crm(m) @ f,
                                       m + crf(m) @ f, inertia(p) @ m]):
        np.testing.assert_allclose(got, expected, atol=1e-9)
    np.testing.assert_allclose(inertia(P[1]), X.T @ inertia(p) @ X, atol=1e-8)
    assert dot[0] == pytest.approx(m @ f)
    for jtype in (REVOLUTE, PRISMATIC):  # the joint pass: jcalc, then the tree placement
        axis = m[:3] / max(np.linalg.norm(m[:3]), 1e-9) if np.linalg.norm(m[:3]) > 1e-3 else np.array([0, 0, 1.0])
        joint = np.array([[jtype, -1]])
        geom = np.zeros((1, 5, 3))
        geom[0, 0], geom[0, 1:4], geom[0, 4] = axis, X[:3, :3].T, r  # any placement as the tree part
        body = np.zeros((1, BODY_SLOTS, 6))
        update_joints(joint, geom, np.array([f[0]]), Xs, body)
        XJ, S_ref = jcalc(jtype, axis, f[0])
        np.testing.assert_allclose(plucker(Xs[0, :3].T, Xs[0, 3]), XJ @ plucker(geom[0, 1:4], r), atol=1e-9)
        np.testing.assert_allclose(body[0, SUB], S_ref)
