import numpy as np
import pytest

from kernels.errors import KernelError
from kernels.muscles import basis, bind, combine, displace, evaluate, falloff


def test_rational_quadratic_nurbs_draws_an_exact_quarter_circle():
    control = np.array([[1, 0, 0, 1], [1, 1, 0, np.sqrt(0.5)], [0, 1, 0, 1]])
    points = evaluate(control, [0, 0, 0, 1, 1, 1], 2, np.linspace(0, 1, 50))
    np.testing.assert_allclose(np.linalg.norm(points[:, :2], axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(points[[0, -1]], [[1, 0, 0], [0, 1, 0]], atol=1e-12)


def test_bspline_basis_sums_to_one_and_uniform_cubic_has_known_values():
    knots = np.array([0, 0, 0, 0, 1, 2, 3, 3, 3, 3], float)
    first, values = basis(knots, 3, np.linspace(0, 3, 31))
    np.testing.assert_allclose(values.sum(axis=1), 1.0, atol=1e-12)
    assert first.min() == 0 and first.max() == 6 - 1 - 3   # six control points, last span starts at 2
    _, middle = basis(np.arange(8.0), 3, np.array([3.5]))      # uniform knots, centre of a span
    np.testing.assert_allclose(middle[0], [1 / 48, 23 / 48, 23 / 48, 1 / 48])


def test_falloff_codes_follow_equation_3_3():
    x = np.array([0.0, 0.25, 1.0])
    np.testing.assert_allclose(falloff(-1, x), x ** 3)
    np.testing.assert_allclose(falloff(0, x), x ** 2)
    np.testing.assert_allclose(falloff(1, x), x)
    np.testing.assert_allclose(falloff(2, x), np.sin(np.pi * x / 2))
    np.testing.assert_allclose(falloff(3, x), np.sqrt(x))
    np.testing.assert_allclose(falloff(4, x), np.cbrt(x))
    with pytest.raises(KernelError, match=r"^unknown falloff code 7: choose one of \(-1, 0, 1, 2, 3, 4\)$"):
        falloff(7, x)


def straight_muscle():
    """A straight degree-1 curve along x from 0 to 1 m (three control points)."""
    return np.array([[0, 0, 0, 1], [0.5, 0, 0, 1], [1, 0, 0, 1]], float), np.array([0, 0, 0.5, 1, 1], float)


def test_binding_weights_vertices_by_their_distance_to_the_curve():
    control, knots = straight_muscle()
    rest = np.array([[0.3, 0.0, 0.02], [0.6, 0.05, 0.0], [0.5, 0.0, 0.2], [0.8, 0.0, 0.0]])
    binding = bind(rest, control, knots, 1, radius=0.1, falloff_code=0)
    assert list(binding.vertices) == [0, 1, 3]                       # the vertex 0.2 m away is outside
    np.testing.assert_allclose(binding.u, [0.3, 0.6, 0.8], atol=1e-6)
    np.testing.assert_allclose(binding.weight, [0.8 ** 2, 0.5 ** 2, 1.0], atol=1e-6)


def test_moving_a_control_point_displaces_skin_by_curve_motion_times_falloff(any_backend):
    control, knots = straight_muscle()
    rest = np.array([[0.5, 0.05, 0.0], [0.25, 0.0, 0.05], [2.0, 0.0, 0.0]], np.float32)
    binding = bind(rest, control, knots, 1, radius=0.1, falloff_code=1)
    influence = combine([binding], [3], len(rest))
    moved = control.copy()
    moved[1, 1] += 0.04                                              # lift the middle control point
    result = displace(rest, influence, control.astype(np.float32), moved.astype(np.float32), backend=any_backend)
    # vertex 0 sits over the middle (curve moves 0.04, mu 0.5); vertex 1 a quarter along (curve moves 0.02, mu 0.5)
    np.testing.assert_allclose(result[0] - rest[0], [0, 0.02, 0], atol=1e-6)
    np.testing.assert_allclose(result[1] - rest[1], [0, 0.01, 0], atol=1e-6)
    np.testing.assert_array_equal(result[2], rest[2])


def test_muscle_backends_match_numpy_on_the_avatar_arms(avatar, accelerated_backend):
    from media.muscles import muscle_influence, stacked_control_points
    influence = muscle_influence(avatar)
    rest_controls = stacked_control_points(avatar.muscles, np.zeros(len(avatar.muscles)))
    contracted = stacked_control_points(avatar.muscles, np.array([1.0, 0.5, 0.25, 0.8]))
    reference = displace(avatar.vertices, influence, rest_controls, contracted, backend="numpy")
    result = displace(avatar.vertices, influence, rest_controls, contracted, backend=accelerated_backend)
    assert np.abs(result - reference).max() / np.abs(reference).max() < 1e-4
    assert np.linalg.norm(reference - avatar.vertices, axis=1).max() > 0.005


def test_unchanged_curves_leave_the_skin_in_place_and_bad_input_is_rejected():
    control, knots = straight_muscle()
    rest = np.random.default_rng(1).uniform(0, 1, (50, 3)).astype(np.float32)
    influence = combine([bind(rest, control, knots, 1, radius=0.3)], [3], len(rest))
    controls = control.astype(np.float32)
    np.testing.assert_array_equal(displace(rest, influence, controls, controls, backend="numpy"), rest)
    with pytest.raises(KernelError, match=r"^NURBS weights must be positive$"):
        bad = controls.copy()
        bad[0, 3] = 0
        displace(rest, influence, controls, bad)
    with pytest.raises(KernelError, match=r"^knots must not decrease and must span a non-empty parameter range$"):
        bind(rest, control, [0, 1, 0.5, 1, 1], 1, radius=0.1)
    with pytest.raises(KernelError, match=r"^muscle radius must be positive, got 0$"):
        bind(rest, control, knots, 1, radius=0)
