"""Tests of vibra.mechanics.rigid: inertia tensors, Huygens' theorem, compound pendulums, spring assemblies.

Truth: the defining integrals I = int (|r|^2 1 - r r^T) dm evaluated here by Gauss-Legendre /
uniform-angle quadrature (exact for these polynomial-in-coordinates integrands), textbook
table values, seed 000's 2L/3 and a + K^2/a, seed 004's Huygens matrix, closed-form
frequencies, and a finite-difference Hessian of the exact (finite-rotation) spring energies
built with scipy.spatial.transform.Rotation.
"""

from __future__ import annotations

import dataclasses
import doctest

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vibra.mechanics.rigid import (
    LinearSpring,
    RigidBody,
    TorsionSpring,
    block_inertia,
    compound_pendulum,
    cylinder_inertia,
    disk_inertia,
    equivalent_length,
    hollow_sphere_inertia,
    parallel_axis,
    ring_inertia,
    rigid_body_system,
    rod_inertia,
    sphere_inertia,
)

# Quadrature sums of a few dozen to a few thousand terms: ~1e-15 relative rounding each.
QUADRATURE_RTOL = 1e-13


# ---------------------------------------------------------------------- quadrature clouds
def _legendre(low, high, n=6):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (high - low) * x + 0.5 * (high + low), 0.5 * (high - low) * w


def _angles(n=12):
    return np.arange(n) * 2 * np.pi / n, np.full(n, 2 * np.pi / n)


def _tensor(points, weights):
    r2 = np.einsum("ij,ij->i", points, points)
    return np.einsum("i,jk->jk", weights * r2, np.eye(3)) - np.einsum("i,ij,ik->jk", weights, points, points)


def _cloud(kind, mass, *dims):
    """(points (n, 3), weights (n,)) of a uniform solid centred at 0, symmetry axis z."""
    if kind == "rod":
        (L,) = dims
        z, w = _legendre(-L / 2, L / 2)
        return np.column_stack([0 * z, 0 * z, z]), mass / L * w
    if kind == "ring":
        (R,) = dims
        phi, w = _angles()
        return np.column_stack([R * np.cos(phi), R * np.sin(phi), 0 * phi]), mass * w / (2 * np.pi)
    if kind in ("disk", "cylinder"):
        R = dims[0]
        h = dims[1] if kind == "cylinder" else None
        r, wr = _legendre(0.0, R)
        phi, wp = _angles()
        z, wz = (np.array([0.0]), np.array([1.0])) if h is None else _legendre(-h / 2, h / 2)
        rr, pp, zz = (a.ravel() for a in np.meshgrid(r, phi, z, indexing="ij"))
        ww = np.einsum("i,j,k->ijk", wr * r, wp, wz).ravel()
        volume = np.pi * R**2 * (1.0 if h is None else h)
        return np.column_stack([rr * np.cos(pp), rr * np.sin(pp), zz]), mass / volume * ww
    if kind in ("sphere", "shell"):
        R = dims[0]
        r, wr = (_legendre(0.0, R) if kind == "sphere" else (np.array([R]), np.array([1.0])))
        c, wc = _legendre(-1.0, 1.0)
        phi, wp = _angles()
        rr, cc, pp = (a.ravel() for a in np.meshgrid(r, c, phi, indexing="ij"))
        radial = wr * r**2 if kind == "sphere" else wr
        ww = np.einsum("i,j,k->ijk", radial, wc, wp).ravel()
        s = np.sqrt(1 - cc**2)
        norm = ww.sum()
        return np.column_stack([rr * s * np.cos(pp), rr * s * np.sin(pp), rr * cc]), mass * ww / norm
    if kind == "block":
        axes = [_legendre(-d / 2, d / 2) for d in dims]
        grid = np.meshgrid(*[a[0] for a in axes], indexing="ij")
        ww = np.einsum("i,j,k->ijk", *[a[1] for a in axes]).ravel()
        return np.column_stack([g.ravel() for g in grid]), mass * ww / np.prod(dims)
    raise AssertionError(kind)


SOLIDS = [
    ("rod", rod_inertia, (2.0, 1.7)),
    ("ring", ring_inertia, (0.7, 0.4)),
    ("disk", disk_inertia, (1.3, 0.25)),
    ("sphere", sphere_inertia, (5.0, 0.3)),
    ("shell", hollow_sphere_inertia, (0.4, 1.2)),
    ("cylinder", cylinder_inertia, (3.0, 0.2, 1.1)),
]


@pytest.mark.parametrize(("kind", "function", "arguments"), SOLIDS)
def test_inertia_tensors_against_quadrature(kind, function, arguments):
    points, weights = _cloud(kind, *arguments)
    np.testing.assert_allclose(weights.sum(), arguments[0], rtol=QUADRATURE_RTOL)
    np.testing.assert_allclose(function(*arguments), _tensor(points, weights), rtol=QUADRATURE_RTOL,
                               atol=QUADRATURE_RTOL * arguments[0] * max(arguments[1:]) ** 2)


def test_block_inertia_against_quadrature():
    points, weights = _cloud("block", 2.5, 0.3, 0.7, 1.9)
    np.testing.assert_allclose(block_inertia(2.5, (0.3, 0.7, 1.9)), _tensor(points, weights), rtol=QUADRATURE_RTOL,
                               atol=1e-15)


def test_inertia_tables():
    # Textbook tables (e.g. seed 004 annex 8.1; any mechanics handbook), about the centre.
    m, R, L, h = 2.0, 0.5, 3.0, 0.8
    np.testing.assert_allclose(np.diag(rod_inertia(m, L)), [m * L**2 / 12, m * L**2 / 12, 0.0])
    np.testing.assert_allclose(np.diag(disk_inertia(m, R)), [m * R**2 / 4, m * R**2 / 4, m * R**2 / 2])
    np.testing.assert_allclose(np.diag(ring_inertia(m, R)), [m * R**2 / 2, m * R**2 / 2, m * R**2])
    np.testing.assert_allclose(sphere_inertia(m, R), 2 / 5 * m * R**2 * np.eye(3))
    np.testing.assert_allclose(hollow_sphere_inertia(m, R), 2 / 3 * m * R**2 * np.eye(3))
    side = m * (3 * R**2 + h**2) / 12
    np.testing.assert_allclose(np.diag(cylinder_inertia(m, R, h)), [side, side, m * R**2 / 2])
    np.testing.assert_allclose(np.diag(block_inertia(m, (1.0, 2.0, 3.0))), [m * 13 / 12, m * 10 / 12, m * 5 / 12])


def test_parallel_axis_against_quadrature_and_seed_matrix():
    points, weights = _cloud("block", 1.5, 0.4, 0.9, 0.2)
    offset = np.array([0.3, -0.5, 0.8])  # AG: the point A is at -offset from G
    shifted = _tensor(points + offset, weights)  # the same body with A at the origin
    result = parallel_axis(block_inertia(1.5, (0.4, 0.9, 0.2)), 1.5, offset)
    np.testing.assert_allclose(result, shifted, rtol=QUADRATURE_RTOL)
    a, b, c = offset
    seed = 1.5 * np.array([[b * b + c * c, -a * b, -a * c], [-a * b, a * a + c * c, -b * c], [-a * c, -b * c, a * a + b * b]])
    np.testing.assert_allclose(result - block_inertia(1.5, (0.4, 0.9, 0.2)), seed, rtol=1e-14)
    body = RigidBody(1.5, block_inertia(1.5, (0.4, 0.9, 0.2)), center=(1.0, 1.0, 1.0))
    np.testing.assert_allclose(body.inertia_about(np.array([1.0, 1.0, 1.0]) - offset), result, rtol=1e-15)


def test_parallel_axis_of_a_rotated_body(rng):
    # A block turned by a random rotation has products of inertia; Huygens still holds.
    turn = Rotation.random(random_state=np.random.default_rng(rng.integers(2**32))).as_matrix()
    points, weights = _cloud("block", 0.8, 0.5, 0.2, 0.3)
    points = points @ turn.T
    offset = rng.normal(size=3)
    tensor = turn @ block_inertia(0.8, (0.5, 0.2, 0.3)) @ turn.T
    np.testing.assert_allclose(parallel_axis(tensor, 0.8, offset), _tensor(points + offset, weights),
                               rtol=1e-12, atol=1e-14)


# ---------------------------------------------------------------------- compound pendulum
def test_uniform_rod_hung_from_its_end_is_a_pendulum_of_two_thirds_its_length():
    L = 1.2
    rod = RigidBody(0.5, rod_inertia(0.5, L), center=(0.0, 0.0, -L / 2), name="rod")
    # Seed 000, problem I: l = a + K^2 / a = 2L/3. Through a 1x1 generalised eigenproblem:
    # a few ulps.
    np.testing.assert_allclose(equivalent_length(rod, (0.0, 0.0, 0.0)), 2 * L / 3, rtol=1e-13)
    np.testing.assert_allclose(equivalent_length(rod, (0.0, 0.0, 0.0), axis=(1.0, 1.0, 0.0), g=1.62), 2 * L / 3,
                               rtol=1e-13)


@pytest.mark.parametrize(
    ("tensor", "a", "k2"),
    [
        (sphere_inertia(2.0, 0.3), 0.9, 2 / 5 * 0.3**2),
        (cylinder_inertia(2.0, 0.1, 0.6), 0.3, (3 * 0.1**2 + 0.6**2) / 12),
        (disk_inertia(2.0, 0.4), 0.4, 0.4**2 / 4),  # disk a = R below the pivot, swinging about x (I_xx = m R^2/4)
    ],
)
def test_compound_pendulum_length_a_plus_k2_over_a(tensor, a, k2):
    body = RigidBody(2.0, tensor, center=(0.0, 0.2, -a))
    pivot = (0.0, 0.2, 0.0)
    np.testing.assert_allclose(equivalent_length(body, pivot, g=9.81), a + k2 / a, rtol=1e-13)
    system = compound_pendulum(body, pivot, g=9.81)
    np.testing.assert_allclose(system.mass_matrix(), [[2.0 * (k2 + a * a)]], rtol=1e-14)
    np.testing.assert_allclose(system.hessian().toarray(), [[2.0 * 9.81 * a]], rtol=1e-14)
    assert system.labels == ("theta",)


def test_offset_along_the_axis_keeps_the_equilibrium():
    # G displaced along the axis (y) is still below it: l = a + K_yy^2 / a, K_yy^2 = I_yy / m.
    block = RigidBody(1.0, block_inertia(1.0, (0.2, 0.4, 0.6)), center=(0.0, 0.5, -1.0))
    k2 = (0.2**2 + 0.6**2) / 12
    np.testing.assert_allclose(equivalent_length(block, (0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0)), 1.0 + k2, rtol=1e-13)


def test_compound_pendulum_rejects_bodies_off_equilibrium():
    sphere = RigidBody(1.0, sphere_inertia(1.0, 0.1), center=(0.0, 0.3, -1.0))
    with pytest.raises(ValueError, match="q0 is not an equilibrium"):
        compound_pendulum(sphere, (0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    above = RigidBody(1.0, sphere_inertia(1.0, 0.1), center=(0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="centre of mass is above the axis"):
        equivalent_length(above, (0.0, 0.0, 0.0))
    below = RigidBody(1.0, sphere_inertia(1.0, 0.1), center=(0.0, 0.0, -1.0))
    with pytest.raises(ValueError, match="no restoring torque.*on or along the axis"):
        equivalent_length(below, (0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0))


# ---------------------------------------------------------------------- assemblies
def _ball(mass=1.0, center=(0.0, 0.0, 0.0), name="ball"):
    return RigidBody(mass, sphere_inertia(mass, 0.1), center=center, name=name)


def test_free_body_has_six_zero_modes():
    body = RigidBody(2.0, block_inertia(2.0, (0.3, 0.5, 0.7)), center=(1.0, 2.0, 3.0))
    modes = rigid_body_system([body]).modes()
    assert modes.n_modes == 6
    np.testing.assert_array_equal(modes.omega, 0.0)


def test_two_bodies_on_one_spring_through_their_centres():
    k, m1, m2 = 40.0, 1.5, 0.5
    bodies = [_ball(m1, (0.0, 0.0, 0.0), "a"), _ball(m2, (0.6, 0.8, 0.0), "b")]
    spring = LinearSpring(0, (0.0, 0.0, 0.0), 1, (0.6, 0.8, 0.0), k)
    modes = rigid_body_system(bodies, [spring]).modes()
    # K has rank 1: 11 zero modes, one at omega^2 = k (1/m1 + 1/m2) (reduced mass).
    assert modes.zero_modes().sum() == 11
    np.testing.assert_allclose(modes.omega_squared[-1], k * (1 / m1 + 1 / m2), rtol=1e-12)


def test_off_centre_spring_rank_one_frequency():
    # A spring attached off the centres also turns the bodies: omega^2 = k b^T M^-1 b with
    # b = (-e, -(r_a x e), e, r_b x e); still one non-zero mode.
    k = 25.0
    bodies = [RigidBody(1.0, block_inertia(1.0, (0.4, 0.2, 0.3)), center=(0.0, 0.0, 0.0), name="a"),
              RigidBody(2.0, cylinder_inertia(2.0, 0.1, 0.5), center=(1.0, 0.0, 0.0), name="b")]
    pa, pb = np.array([0.1, 0.05, 0.1]), np.array([0.9, 0.2, -0.1])
    modes = rigid_body_system(bodies, [LinearSpring(0, pa, 1, pb, k)]).modes()
    e = (pb - pa) / np.linalg.norm(pb - pa)
    ra, rb = pa - bodies[0].center, pb - bodies[1].center
    expected = k * (1 / 1.0 + 1 / 2.0 + np.cross(ra, e) @ np.linalg.solve(bodies[0].inertia, np.cross(ra, e))
                    + np.cross(rb, e) @ np.linalg.solve(bodies[1].inertia, np.cross(rb, e)))
    assert modes.zero_modes().sum() == 11
    np.testing.assert_allclose(modes.omega_squared[-1], expected, rtol=1e-12)


def test_torsion_spring_disk():
    # A disk on a spiral spring to the ground about its axis: omega = sqrt(C / (m R^2 / 2)).
    m, R, C = 0.8, 0.3, 5.0
    disk = RigidBody(m, cylinder_inertia(m, R, 0.01), name="disk")
    system = rigid_body_system([disk], torsion_springs=[TorsionSpring(None, 0, C, axis=(0.0, 0.0, 1.0))])
    modes = system.modes()
    assert modes.zero_modes().sum() == 5
    np.testing.assert_allclose(modes.omega[-1], np.sqrt(C / (m * R**2 / 2)), rtol=1e-12)
    assert system.labels[:6] == ("disk.x", "disk.y", "disk.z", "disk.rx", "disk.ry", "disk.rz")


def test_mass_matrix_blocks():
    bodies = [_ball(1.0, name="p"), RigidBody(2.0, block_inertia(2.0, (0.1, 0.2, 0.3)), name="p")]
    system = rigid_body_system(bodies)
    M = system.mass_matrix()
    np.testing.assert_array_equal(M[:3, :3], np.eye(3))
    np.testing.assert_array_equal(M[9:, 9:], bodies[1].inertia)
    np.testing.assert_array_equal(M[:6, 6:], 0.0)
    assert system.labels[0] == "p0.x" and system.labels[6] == "p1.x"  # repeated names get indices


def test_stiffness_matches_finite_difference_hessian_of_exact_energy(rng):
    bodies = [RigidBody(1.0 + i, block_inertia(1.0 + i, (0.3, 0.4, 0.5)), center=rng.normal(size=3), name=f"b{i}")
              for i in range(3)]
    springs = [
        LinearSpring(0, bodies[0].center + rng.normal(scale=0.2, size=3), 1, bodies[1].center + rng.normal(scale=0.2, size=3), 30.0),
        LinearSpring(1, bodies[1].center + rng.normal(scale=0.2, size=3), 2, bodies[2].center, 12.0),
        LinearSpring(None, np.zeros(3), 2, bodies[2].center + rng.normal(scale=0.2, size=3), 7.0),
        LinearSpring(0, bodies[0].center, None, bodies[0].center, 3.0, direction=(0.0, 0.0, 1.0)),
    ]
    torsions = [TorsionSpring(0, 1, 2.0, axis=rng.normal(size=3)), TorsionSpring(2, None, 1.5)]
    K = rigid_body_system(bodies, springs, torsions).hessian().toarray()

    def place(x, index, point):
        if index is None:
            return point
        u, theta = x[6 * index:6 * index + 3], x[6 * index + 3:6 * index + 6]
        center = bodies[index].center
        return center + u + Rotation.from_rotvec(theta).apply(point - center)

    def rotation(x, index):
        return Rotation.identity() if index is None else Rotation.from_rotvec(x[6 * index + 3:6 * index + 6])

    def energy(x):
        total = 0.0
        for s in springs:
            a, b = place(x, s.body_a, s.point_a), place(x, s.body_b, s.point_b)
            if s.direction is not None and np.allclose(s.point_a, s.point_b):
                total += 0.5 * s.stiffness * (s.direction @ (b - a)) ** 2  # zero-length spring along its axis
            else:
                rest = np.linalg.norm(s.point_b - s.point_a)
                total += 0.5 * s.stiffness * (np.linalg.norm(b - a) - rest) ** 2
        for t in torsions:
            relative = (rotation(x, t.body_b) * rotation(x, t.body_a).inv()).as_rotvec()
            total += 0.5 * t.stiffness * (relative @ relative if t.axis is None else (t.axis @ relative) ** 2)
        return total

    n, h = K.shape[0], 1e-4
    fd = np.empty((n, n))
    steps = np.eye(n) * h
    for i in range(n):
        for j in range(i, n):
            fd[i, j] = fd[j, i] = (energy(steps[i] + steps[j]) - energy(steps[i] - steps[j])
                                   - energy(-steps[i] + steps[j]) + energy(-steps[i] - steps[j])) / (4 * h * h)
    # Central differences: truncation ~h^2 * (4th derivatives ~ k) ~ 1e-8, rounding
    # ~eps * E / h^2 ~ 1e-8; relative to max|K| ~ 30 that is < 1e-8, tolerance 1e-6.
    np.testing.assert_allclose(K, fd, atol=1e-6 * np.abs(K).max())


# ---------------------------------------------------------------------- frozen results
def test_bodies_and_springs_are_frozen():
    body = _ball()
    spring = LinearSpring(0, (0.0, 0.0, 0.0), None, (1.0, 0.0, 0.0), 1.0)
    torsion = TorsionSpring(0, None, 1.0, axis=(0.0, 0.0, 2.0))
    for item, field in ((body, "mass"), (spring, "stiffness"), (torsion, "stiffness")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(item, field, 2.0)
    for array in (body.inertia, body.center, spring.point_a, spring.direction, torsion.axis):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1.0
    np.testing.assert_allclose(torsion.axis, [0.0, 0.0, 1.0])  # normalised


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("call", "error", "pattern"),
    [
        (lambda: rod_inertia(0.0, 1.0), ValueError, r"mass is 0.0"),
        (lambda: disk_inertia(1.0, -1.0), ValueError, r"radius is -1.0"),
        (lambda: cylinder_inertia(1.0, 1.0, np.nan), ValueError, r"height is nan"),
        (lambda: block_inertia(1.0, (1.0, 2.0)), ValueError, r"size must be a 3-vector"),
        (lambda: block_inertia(1.0, (1.0, 0.0, 2.0)), ValueError, r"size\[1\] is 0.0"),
        (lambda: sphere_inertia("1", 1.0), TypeError, r"mass must be a real number"),
        (lambda: parallel_axis(np.eye(2), 1.0, (0, 0, 0)), ValueError, r"inertia_center must be \(3, 3\)"),
        (lambda: parallel_axis(np.eye(3), 1.0, (0, 0)), ValueError, r"offset must be a 3-vector"),
        (lambda: RigidBody(-1.0, np.eye(3)), ValueError, r"mass is -1.0"),
        (lambda: RigidBody(1.0, -np.eye(3)), ValueError, r"inertia has a negative principal moment"),
        (lambda: RigidBody(1.0, np.diag([1.0, 1.0, 3.0])), ValueError, r"I1 \+ I2 < I3"),
        (lambda: RigidBody(1.0, [[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]]), ValueError, r"inertia is not symmetric"),
        (lambda: RigidBody(1.0, np.eye(3), center=(0.0, 0.0)), ValueError, r"center must be a 3-vector"),
        (lambda: RigidBody(1.0, np.eye(3), name=3), TypeError, r"name must be a str"),
        (lambda: LinearSpring(None, (0, 0, 0), None, (1, 0, 0), 1.0), ValueError, r"body_a and body_b are both None"),
        (lambda: LinearSpring(1, (0, 0, 0), 1, (1, 0, 0), 1.0), ValueError, r"body_a and body_b are both 1"),
        (lambda: LinearSpring(0, (0, 0, 0), None, (0, 0, 0), 1.0), ValueError, r"point_a and point_b coincide"),
        (lambda: LinearSpring(0, (0, 0, 0), None, (1, 0, 0), 0.0), ValueError, r"stiffness is 0.0"),
        (lambda: LinearSpring(0, (0, 0, 0), None, (1, 0, 0), 1.0, direction=(0, 0, 0)), ValueError, r"direction is the zero vector"),
        (lambda: LinearSpring(0.5, (0, 0, 0), None, (1, 0, 0), 1.0), TypeError, r"body_a must be a body index"),
        (lambda: LinearSpring(-1, (0, 0, 0), None, (1, 0, 0), 1.0), ValueError, r"body_a is -1"),
        (lambda: TorsionSpring(None, None, 1.0), ValueError, r"body_a and body_b are both None"),
        (lambda: TorsionSpring(0, 0, 1.0), ValueError, r"body_a and body_b are both 0"),
        (lambda: TorsionSpring(0, None, -2.0), ValueError, r"stiffness is -2.0"),
        (lambda: TorsionSpring(0, None, 1.0, axis=(0, 0, 0)), ValueError, r"axis is the zero vector"),
        (lambda: rigid_body_system([]), ValueError, r"bodies is empty"),
        (lambda: rigid_body_system(_ball()), TypeError, r"bodies must be a sequence of RigidBody"),
        (lambda: rigid_body_system([_ball(), "b"]), TypeError, r"bodies\[1\] must be a RigidBody, got str"),
        (lambda: rigid_body_system([_ball()], [TorsionSpring(0, None, 1.0)]), TypeError, r"springs\[0\] must be a LinearSpring"),
        (lambda: rigid_body_system([_ball()], [LinearSpring(0, (0, 0, 0), 1, (1, 0, 0), 1.0)]), ValueError,
         r"springs\[0\].body_b is 1; body indices run from 0 to 0"),
        (lambda: rigid_body_system([_ball()], torsion_springs=[TorsionSpring(None, 2, 1.0)]), ValueError,
         r"torsion_springs\[0\].body_b is 2"),
        (lambda: rigid_body_system([RigidBody(1.0, rod_inertia(1.0, 1.0), name="rod")]), ValueError,
         r"bodies\[0\] \(rod\) has a singular inertia tensor"),
        (lambda: compound_pendulum("rod", (0, 0, 0)), TypeError, r"body must be a RigidBody"),
        (lambda: compound_pendulum(_ball(center=(0, 0, -1)), (0, 0, 0), axis=(0, 0, 0)), ValueError, r"axis is the zero vector"),
        (lambda: compound_pendulum(_ball(center=(0, 0, -1)), (0, 0)), ValueError, r"pivot must be a 3-vector"),
        (lambda: equivalent_length(_ball(center=(0, 0, -1)), (0, 0, 0), g=0.0), ValueError, r"g is 0.0"),
        (lambda: _ball().inertia_about((0.0, 1.0)), ValueError, r"point must be a 3-vector"),
        (lambda: rigid_body_system([_ball()], springs=None), TypeError, r"springs must be a sequence of LinearSpring"),
    ],
)
def test_bad_input(call, error, pattern):
    with pytest.raises(error, match=pattern):
        call()


def test_rod_without_inertia_about_the_swing_axis():
    rod = RigidBody(1.0, rod_inertia(1.0, 1.0), center=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="no inertia about the axis"):
        compound_pendulum(rod, (0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0))


def test_docstring_examples_run():
    import vibra.mechanics.rigid

    failures, attempted = doctest.testmod(vibra.mechanics.rigid, optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failures == 0
