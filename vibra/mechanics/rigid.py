"""Rigid bodies: inertia tensors, Huygens' theorem, compound pendulums, bodies on springs.

Seed 004: the inertia tensor of a solid about its centre of mass G (section 5.2, annex 8.1),
[I(G)] with I_x = int (y^2 + z^2) dm, products P_xy = int x y dm entering as -P_xy;
Huygens' (parallel-axis) theorem [I(A)] = [I(G)] + m (|d|^2 1 - d d^T) with d = AG;
linear springs (force -k (x - x0)) and spiral (torsion) springs (moment -C (theta - theta0));
the kinetic energy of a solid T = 1/2 m v_G^2 + 1/2 Omega^T [I(G)] Omega (section 7.3).

Conventions: every tensor is (3, 3) in the fixed frame x, y, z, in kg m^2 for SI input.
Bodies of revolution have their axis along z; a thin disk or ring lies in the xy plane.

Small motions of free bodies: each body has 6 coordinates, the displacement u of G and a
small rotation vector theta (rad), so that a body point r0 moves by u + theta x (r0 - G).
Then T = 1/2 sum (m |u'|^2 + theta'^T [I(G)] theta') and the mass matrix is
blockdiag(m 1_3, [I(G)]) per body. Springs are relaxed at equilibrium (rest length = the
distance of their attachment points), so the potential to second order is
1/2 k (e . (dp_b - dp_a))^2 per linear spring of axis e, and 1/2 C (n . (theta_b - theta_a))^2
per torsion spring of axis n (or 1/2 C |theta_b - theta_a|^2 when isotropic). Gravity is not
included in assemblies (it would need the pre-stress of the springs); see `compound_pendulum`
for a body swinging under gravity.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.mechanics.lagrangian import linearize
from vibra._core.frozen import freeze_arrays
from vibra.generalized import GeneralizedSystem
from vibra.system import System
from vibra.units import UnitSystem

__all__ = [
    "RigidBody",
    "LinearSpring",
    "TorsionSpring",
    "rod_inertia",
    "disk_inertia",
    "ring_inertia",
    "sphere_inertia",
    "hollow_sphere_inertia",
    "cylinder_inertia",
    "block_inertia",
    "parallel_axis",
    "compound_pendulum",
    "equivalent_length",
    "rigid_body_system",
]

_AXIS_NAMES = ("x", "y", "z", "rx", "ry", "rz")


# ---------------------------------------------------------------------- checks
_positive_scalar = _validate.positive_scalar
_real_scalar = _validate.real_scalar


def _vector3(value: Any, name: str) -> NDArray[np.float64]:
    vector = _validate.real_array(value, name, ndim=1)
    if vector.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector (x, y, z), got shape {vector.shape}")
    return vector


def _unit3(value: Any, name: str) -> NDArray[np.float64]:
    vector = _vector3(value, name)
    norm = float(np.linalg.norm(vector))
    if norm == 0.0:
        raise ValueError(f"{name} is the zero vector; it must give a direction")
    return vector / norm


# ---------------------------------------------------------------------- inertia tables
def rod_inertia(mass: float, length: float) -> NDArray[np.float64]:
    """(3, 3) inertia of a thin uniform rod along z about its centre, in kg m^2.

    diag(m L^2 / 12, m L^2 / 12, 0): a thin rod has no inertia about its own axis.

    Parameters
    ----------
    mass : float
        m, in kg.
    length : float
        L, in m.

    Examples
    --------
    >>> rod_inertia(3.0, 2.0).diagonal().tolist()  # m L^2 / 12 about x and y
    [1.0, 1.0, 0.0]
    """
    m, L = _positive_scalar(mass, "mass"), _positive_scalar(length, "length")
    side = m * L * L / 12.0
    return np.diag([side, side, 0.0])


def disk_inertia(mass: float, radius: float) -> NDArray[np.float64]:
    """(3, 3) inertia of a thin uniform disk in the xy plane about its centre, in kg m^2.

    diag(m R^2 / 4, m R^2 / 4, m R^2 / 2).

    Examples
    --------
    >>> disk_inertia(2.0, 1.0).diagonal().tolist()  # m R^2 / 4, m R^2 / 4, m R^2 / 2
    [0.5, 0.5, 1.0]
    """
    m, R = _positive_scalar(mass, "mass"), _positive_scalar(radius, "radius")
    return m * R * R * np.diag([0.25, 0.25, 0.5])


def ring_inertia(mass: float, radius: float) -> NDArray[np.float64]:
    """(3, 3) inertia of a thin ring (hoop) in the xy plane about its centre, in kg m^2.

    diag(m R^2 / 2, m R^2 / 2, m R^2).

    Examples
    --------
    >>> ring_inertia(2.0, 1.0).diagonal().tolist()  # m R^2 / 2, m R^2 / 2, m R^2
    [1.0, 1.0, 2.0]
    """
    m, R = _positive_scalar(mass, "mass"), _positive_scalar(radius, "radius")
    return m * R * R * np.diag([0.5, 0.5, 1.0])


def sphere_inertia(mass: float, radius: float) -> NDArray[np.float64]:
    """(3, 3) inertia of a solid uniform sphere about its centre: (2/5) m R^2 1, in kg m^2.

    Examples
    --------
    >>> sphere_inertia(5.0, 1.0).diagonal().tolist()  # 2 m R^2 / 5
    [2.0, 2.0, 2.0]
    """
    m, R = _positive_scalar(mass, "mass"), _positive_scalar(radius, "radius")
    return 0.4 * m * R * R * np.eye(3)


def hollow_sphere_inertia(mass: float, radius: float) -> NDArray[np.float64]:
    """(3, 3) inertia of a thin spherical shell about its centre: (2/3) m R^2 1, in kg m^2.

    Examples
    --------
    >>> hollow_sphere_inertia(3.0, 1.0).diagonal().tolist()  # 2 m R^2 / 3
    [2.0, 2.0, 2.0]
    """
    m, R = _positive_scalar(mass, "mass"), _positive_scalar(radius, "radius")
    return (2.0 / 3.0) * m * R * R * np.eye(3)


def cylinder_inertia(mass: float, radius: float, height: float) -> NDArray[np.float64]:
    """(3, 3) inertia of a solid uniform cylinder, axis z, about its centre, in kg m^2.

    diag(m (3 R^2 + h^2) / 12, m (3 R^2 + h^2) / 12, m R^2 / 2).

    Examples
    --------
    >>> cylinder_inertia(12.0, 1.0, 2.0).diagonal().tolist()  # m (3 R^2 + h^2) / 12, m R^2 / 2
    [7.0, 7.0, 6.0]
    """
    m, R = _positive_scalar(mass, "mass"), _positive_scalar(radius, "radius")
    h = _positive_scalar(height, "height")
    side = m * (3.0 * R * R + h * h) / 12.0
    return np.diag([side, side, 0.5 * m * R * R])


def block_inertia(mass: float, size: ArrayLike) -> NDArray[np.float64]:
    """(3, 3) inertia of a uniform rectangular block about its centre, in kg m^2.

    Sides (a, b, c) along x, y, z: diag(m (b^2 + c^2), m (a^2 + c^2), m (a^2 + b^2)) / 12
    (Bentahar's parallelepiped).

    Parameters
    ----------
    mass : float
        m, in kg.
    size : (3,) array_like
        Side lengths (a, b, c), in m, each > 0.

    Examples
    --------
    >>> block_inertia(12.0, (1.0, 2.0, 3.0)).diagonal().tolist()  # m (b^2 + c^2) / 12, ...
    [13.0, 10.0, 5.0]
    """
    m = _positive_scalar(mass, "mass")
    sides = _vector3(size, "size")
    _validate.positive(sides, "size", "side length")
    a2, b2, c2 = sides**2
    return m / 12.0 * np.diag([b2 + c2, a2 + c2, a2 + b2])


def parallel_axis(inertia_center: ArrayLike, mass: float, offset: ArrayLike) -> NDArray[np.float64]:
    """Huygens' theorem: the (3, 3) inertia about a point A, in kg m^2 (Bentahar, Mécanique générale).

    [I(A)] = [I(G)] + m [[b^2 + c^2, -ab, -ac], [-ab, a^2 + c^2, -bc], [-ac, -bc, a^2 + b^2]]
    with (a, b, c) = AG.

    Parameters
    ----------
    inertia_center : (3, 3) array_like
        [I(G)], the inertia about the centre of mass, in kg m^2.
    mass : float
        m, in kg.
    offset : (3,) array_like
        AG = G - A, the vector from A to the centre of mass, in m.

    Examples
    --------
    >>> parallel_axis(rod_inertia(3.0, 2.0), 3.0, (0.0, 0.0, 1.0)).diagonal().tolist()  # + m d^2 off the axis
    [4.0, 4.0, 0.0]
    """
    tensor = _inertia_tensor(inertia_center, "inertia_center")
    m = _positive_scalar(mass, "mass")
    d = _vector3(offset, "offset")
    return tensor + m * (float(d @ d) * np.eye(3) - np.outer(d, d))


def _inertia_tensor(value: Any, name: str) -> NDArray[np.float64]:
    tensor = _validate.real_array(value, name, ndim=2)
    if tensor.shape != (3, 3):
        raise ValueError(f"{name} must be (3, 3), got shape {tensor.shape}")
    tensor = np.asarray(_validate.symmetric(tensor, name))
    principal = np.linalg.eigvalsh(tensor)
    slack = 1e-12 * max(float(np.abs(principal).max()), np.finfo(float).tiny)
    if principal[0] < -slack:
        raise ValueError(
            f"{name} has a negative principal moment {principal[0]:.4g}; an inertia tensor is positive semi-definite"
        )
    if principal[0] + principal[1] < principal[2] - slack:
        raise ValueError(
            f"{name} has principal moments {np.array2string(principal, precision=4)} with I1 + I2 < I3; "
            "no mass distribution has such a tensor"
        )
    return tensor


# ---------------------------------------------------------------------- bodies and springs
@dataclass(frozen=True, eq=False)
class RigidBody:
    """A rigid body at rest: mass, inertia about its centre of mass, and where that centre is.

    Attributes
    ----------
    mass : float
        m, in kg.
    inertia : (3, 3) ndarray
        [I(G)], the inertia tensor about the centre of mass in the fixed axes, in kg m^2
        (symmetric, positive semi-definite, principal moments obeying I1 + I2 >= I3).
    center : (3,) ndarray
        Position of the centre of mass G at equilibrium, in m.
    name : str
        Used to label the body's coordinates.

    Raises
    ------
    ValueError
        mass not positive, inertia not a valid tensor, center not a 3-vector.
    """

    mass: float
    inertia: NDArray[np.float64]
    center: NDArray[np.float64] = (0.0, 0.0, 0.0)  # type: ignore[assignment]  # becomes an ndarray
    name: str = "body"

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", _positive_scalar(self.mass, "mass"))
        object.__setattr__(self, "inertia", _inertia_tensor(self.inertia, "inertia"))
        object.__setattr__(self, "center", _vector3(self.center, "center"))
        if not isinstance(self.name, str):
            raise TypeError(f"name must be a str, got {type(self.name).__name__}")
        freeze_arrays(self)

    def inertia_about(self, point: ArrayLike) -> NDArray[np.float64]:
        """(3, 3) inertia about `point` (m), by Huygens' theorem, in kg m^2."""
        return parallel_axis(self.inertia, self.mass, self.center - _vector3(point, "point"))


@dataclass(frozen=True, eq=False)
class LinearSpring:
    """A linear spring k between two attachment points, relaxed at equilibrium.

    Attributes
    ----------
    body_a, body_b : int or None
        Indices of the bodies it joins in the assembly; None is the fixed ground.
    point_a, point_b : (3,) ndarray
        Attachment points at equilibrium, in m (fixed-frame coordinates).
    stiffness : float
        k, in N/m.
    direction : (3,) ndarray or None
        Unit axis of the spring; by default (point_b - point_a) normalised. Required when
        the two points coincide (a zero-length spring acting along one axis).
    """

    body_a: int | None
    point_a: NDArray[np.float64]
    body_b: int | None
    point_b: NDArray[np.float64]
    stiffness: float
    direction: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        _body_pair(self.body_a, self.body_b, "a spring")
        object.__setattr__(self, "point_a", _vector3(self.point_a, "point_a"))
        object.__setattr__(self, "point_b", _vector3(self.point_b, "point_b"))
        object.__setattr__(self, "stiffness", _positive_scalar(self.stiffness, "stiffness"))
        if self.direction is None:
            axis = self.point_b - self.point_a
            scale = max(float(np.abs(self.point_a).max()), float(np.abs(self.point_b).max()), 1.0)
            if np.linalg.norm(axis) <= 1e-12 * scale:
                raise ValueError(
                    "point_a and point_b coincide; give direction for a zero-length spring"
                )
            object.__setattr__(self, "direction", axis / np.linalg.norm(axis))
        else:
            object.__setattr__(self, "direction", _unit3(self.direction, "direction"))
        freeze_arrays(self)


@dataclass(frozen=True, eq=False)
class TorsionSpring:
    """A spiral (torsion) spring of stiffness C on the relative rotation of two bodies.

    Seed 004: moment -C (theta - theta0) about its axis.

    Attributes
    ----------
    body_a, body_b : int or None
        Indices of the bodies; None is the fixed ground.
    stiffness : float
        C, in N m / rad.
    axis : (3,) ndarray or None
        Unit axis n: energy C (n . (theta_b - theta_a))^2 / 2. None: isotropic,
        C |theta_b - theta_a|^2 / 2 (a torsion spring about every axis).
    """

    body_a: int | None
    body_b: int | None
    stiffness: float
    axis: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        _body_pair(self.body_a, self.body_b, "a torsion spring")
        object.__setattr__(self, "stiffness", _positive_scalar(self.stiffness, "stiffness"))
        if self.axis is not None:
            object.__setattr__(self, "axis", _unit3(self.axis, "axis"))
        freeze_arrays(self)


def _body_pair(body_a: Any, body_b: Any, what: str) -> None:
    """Check the two body indices of `what` (a spring): each an int >= 0 or None, not equal."""
    _body_index(body_a, "body_a")
    _body_index(body_b, "body_b")
    if body_a is None and body_b is None:
        raise ValueError(f"body_a and body_b are both None; {what} must hold at least one body")
    if body_a is not None and body_a == body_b:
        raise ValueError(f"body_a and body_b are both {body_a}; {what} joins two different bodies")


def _body_index(value: Any, name: str) -> None:
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be a body index (int) or None for the ground, got {type(value).__name__}")
    if value < 0:
        raise ValueError(f"{name} is {value}; body indices are >= 0 (None is the ground)")


# ---------------------------------------------------------------------- compound pendulum
def compound_pendulum(
    body: RigidBody, pivot: ArrayLike, axis: ArrayLike = (1.0, 0.0, 0.0), *, g: float = 9.81,
    units: str | UnitSystem = "SI",
) -> GeneralizedSystem:
    """A rigid body swinging about a fixed axis through `pivot`, gravity along -z.

    Built with `vibra.mechanics.lagrangian.linearize` from the exact T and V in the swing angle
    theta (Vieille 1849, problem I; Bentahar, Mécanique générale, section 7.6): the centre of mass moves on
    G(theta) = P + R_n(theta) (G - P) (Rodrigues' rotation about the unit axis n), and

        T = 1/2 (n^T [I(P)] n) theta'^2,   V = m g z_G(theta),

    with [I(P)] from Huygens' theorem. The result has one coordinate, ``"theta"`` (rad):
    M = n^T [I(P)] n (kg m^2) and K = m g a (J/rad^2), a the distance of G from the axis,
    so that the equivalent simple pendulum has the length l = g / omega^2 = a + K^2 / a.

    Parameters
    ----------
    body : RigidBody
        The body at rest; its centre of mass must hang directly below the axis.
    pivot : (3,) array_like
        A point of the axis, in m.
    axis : (3,) array_like
        Direction of the (fixed) rotation axis; normalised here.
    g : float
        Gravitational acceleration, in m/s^2.
    units : str or UnitSystem
        Unit system of the result.

    Raises
    ------
    TypeError
        body not a RigidBody.
    ValueError
        Bad pivot or axis; the body not at equilibrium under gravity (from `linearize`);
        no inertia about the axis.

    Examples
    --------
    >>> rod = RigidBody(mass=3.0, inertia=rod_inertia(3.0, 2.0), center=(0.0, 0.0, -1.0), name="rod")
    >>> pendulum = compound_pendulum(rod, (0.0, 0.0, 0.0), g=9.81)
    >>> round(float(pendulum.modes().omega_squared[0]), 10)  # g / (2 L / 3), L = 2
    7.3575
    """
    if not isinstance(body, RigidBody):
        raise TypeError(f"body must be a RigidBody, got {type(body).__name__}")
    P = _vector3(pivot, "pivot")
    n = _unit3(axis, "axis")
    gravity = _positive_scalar(g, "g")
    d = body.center - P
    inertia = float(n @ body.inertia_about(P) @ n)
    if not inertia > 0:
        raise ValueError("the body has no inertia about the axis; it cannot swing as a pendulum")
    theta, theta_dot = sympy.symbols("theta theta_dot")
    n_s = sympy.Matrix([sympy.Float(x) for x in n])
    d_s = sympy.Matrix([sympy.Float(x) for x in d])
    rotated = (d_s * sympy.cos(theta) + n_s.cross(d_s) * sympy.sin(theta)
               + n_s * n_s.dot(d_s) * (1 - sympy.cos(theta)))
    T = sympy.Rational(1, 2) * sympy.Float(inertia) * theta_dot**2
    V = sympy.Float(body.mass * gravity) * rotated[2]
    return linearize(T, V, [theta], [theta_dot], [0.0], {}, units=units,
                     name=f"{body.name} compound pendulum")


def equivalent_length(body: RigidBody, pivot: ArrayLike, axis: ArrayLike = (1.0, 0.0, 0.0), *,
                      g: float = 9.81) -> float:
    """Length l = g / omega^2 of the simple pendulum that swings like the body, in m.

    omega comes from the normal mode of `compound_pendulum` (through the core solver); for
    a body whose centre of mass lies a below the axis, l = a + K^2 / a with m K^2 its
    inertia about the parallel axis through G (Vieille 1849: 2L/3 for a uniform rod hung from
    one end). Arguments as in `compound_pendulum`.

    Raises
    ------
    ValueError
        As `compound_pendulum`; also when gravity gives no restoring torque (G on the axis,
        or a vertical axis) or G sits above the axis (an unstable equilibrium).

    Examples
    --------
    A uniform rod of length 1.2 m hung from one end swings like a simple pendulum of
    length 2L/3 = 0.8 m (Vieille 1849, problem I):

    >>> from vibra.mechanics.rigid import RigidBody, equivalent_length, rod_inertia
    >>> rod = RigidBody(0.5, rod_inertia(0.5, 1.2), center=(0.0, 0.0, -0.6))
    >>> round(equivalent_length(rod, pivot=(0.0, 0.0, 0.0)), 12)
    0.8
    """
    system = compound_pendulum(body, pivot, axis, g=g)
    stiffness = float(system.hessian().toarray()[0, 0])
    scale = body.mass * _positive_scalar(g, "g") * max(float(np.linalg.norm(body.center - np.asarray(pivot, float))), 1.0)
    if stiffness <= 1e-12 * scale:
        where = "above" if stiffness < 0 else "on or along"
        raise ValueError(
            f"gravity gives no restoring torque about this axis (K = {stiffness:.3g} J/rad^2): the centre "
            f"of mass is {where} the axis; a pendulum needs it below"
        )
    omega = float(system.modes().omega[0])
    return float(g) / omega**2


# ---------------------------------------------------------------------- assemblies
def rigid_body_system(
    bodies: Sequence[RigidBody],
    springs: Sequence[LinearSpring] = (),
    torsion_springs: Sequence[TorsionSpring] = (),
    *,
    units: str | UnitSystem = "SI",
    name: str = "rigid bodies",
) -> GeneralizedSystem:
    """Rigid bodies joined by linear and torsion springs: a `System` with 6 dofs per body.

    Coordinates per body (in this order): the displacement of its centre of mass
    (x, y, z, in m) and its small rotation vector (rx, ry, rz, in rad). The mass matrix is
    blockdiag(m 1_3, [I(G)]) per body (kg and kg m^2); K = sum_s k_s b_s b_s^T, where a
    linear spring's row b_s holds +-(e, r x e) on its two bodies (r = attachment point -
    centre of mass, e its axis: e . (u + theta x r) = (e, r x e) . (u, theta)), and a
    torsion spring's holds +-(0, n). A body joined to nothing moves freely: 6 zero modes.

    Parameters
    ----------
    bodies : sequence of RigidBody
        Every body must have a positive-definite inertia tensor (a thin rod does not).
    springs : sequence of LinearSpring
        Linear springs (N/m), relaxed at equilibrium.
    torsion_springs : sequence of TorsionSpring
        Spiral springs (N m / rad).
    units : str or UnitSystem
        Unit system of the result.
    name : str
        Name used in reports.

    Returns
    -------
    GeneralizedSystem
        In generalised coordinates, 6 * len(bodies) dofs labelled ``"<body>.x"`` ...
        ``"<body>.rz"`` (the body's name, made unique with its index when repeated).

    Raises
    ------
    TypeError
        An entry of the wrong type.
    ValueError
        No bodies; a body index out of range; a body with a singular inertia tensor.
    """
    body_list = _typed_list(bodies, "bodies", RigidBody)
    if not body_list:
        raise ValueError("bodies is empty; give at least one RigidBody")
    spring_list = _typed_list(springs, "springs", LinearSpring)
    torsion_list = _typed_list(torsion_springs, "torsion_springs", TorsionSpring)
    n_bodies = len(body_list)
    for kind, items in (("springs", spring_list), ("torsion_springs", torsion_list)):
        for s, spring in enumerate(items):
            for field in ("body_a", "body_b"):
                index = getattr(spring, field)
                if index is not None and index >= n_bodies:
                    raise ValueError(
                        f"{kind}[{s}].{field} is {index}; body indices run from 0 to {n_bodies - 1}"
                    )
    n_dof = 6 * n_bodies
    M = np.zeros((n_dof, n_dof))
    for i, body in enumerate(body_list):
        principal = np.linalg.eigvalsh(body.inertia)
        if not principal[0] > 1e-12 * principal[-1]:
            raise ValueError(
                f"bodies[{i}] ({body.name}) has a singular inertia tensor (principal moments "
                f"{np.array2string(principal, precision=4)} kg m^2); a free body needs inertia about "
                "every axis (model a rod as a thin cylinder)"
            )
        M[6 * i:6 * i + 3, 6 * i:6 * i + 3] = body.mass * np.eye(3)
        M[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = body.inertia
    K = np.zeros((n_dof, n_dof))
    for spring in spring_list:
        row = np.zeros(n_dof)
        e = spring.direction
        for index, point, sign in ((spring.body_a, spring.point_a, -1.0), (spring.body_b, spring.point_b, 1.0)):
            if index is not None:
                arm = point - body_list[index].center
                row[6 * index:6 * index + 3] += sign * e
                row[6 * index + 3:6 * index + 6] += sign * np.cross(arm, e)
        K += spring.stiffness * np.outer(row, row)
    for torsion in torsion_list:
        axes = np.eye(3) if torsion.axis is None else torsion.axis[None, :]
        for n in axes:
            row = np.zeros(n_dof)
            for index, sign in ((torsion.body_a, -1.0), (torsion.body_b, 1.0)):
                if index is not None:
                    row[6 * index + 3:6 * index + 6] += sign * n
            K += torsion.stiffness * np.outer(row, row)
    names = [body.name for body in body_list]
    labels = [
        f"{body.name if names.count(body.name) == 1 else f'{body.name}{i}'}.{axis}"
        for i, body in enumerate(body_list) for axis in _AXIS_NAMES
    ]
    return System.generalized(M, K, coordinates=labels, units=units, name=name)


def _typed_list(value: Any, name: str, kind: type) -> list[Any]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise TypeError(f"{name} must be a sequence of {kind.__name__}, got {type(value).__name__}")
    for i, item in enumerate(value):
        if not isinstance(item, kind):
            raise TypeError(f"{name}[{i}] must be a {kind.__name__}, got {type(item).__name__}")
    return list(value)
