"""Builders of gyroscopic systems: a charge in a magnetic field, the Foucault pendulum, a spinning wheel.

Each writes its Lagrangian in sympy and hands it to `vibra.mechanics.linearization.linearize`, which
keeps the velocity-linear terms as the skew matrix G; the result is a
`vibra.generalized.GeneralizedSystem` whose `modes()` is a `vibra.solvers.structured.quadratic.QuadraticModes`.

- `charged_particle`: a charge q of mass m in an isotropic 2-D harmonic well (omega0) and a
  uniform field B along z (Kneller, Mécanique analytique, example 4):
  L = m (x'^2 + y'^2) / 2 - m omega0^2 (x^2 + y^2) / 2 + (q B / 2)(x y' - y x'),
  frequencies sqrt(omega0^2 + omega_c^2 / 4) -+ omega_c / 2 with omega_c = q B / m.
- `foucault_pendulum`: a pendulum of length l at latitude phi on a planet turning at Omega,
  small swings (x, y) of the bob in the planet's frame, with the Coriolis term of the vertical
  component Omega sin(phi) (the centrifugal term is absorbed into g):
  L = (x'^2 + y'^2) / 2 + Omega sin(phi) (x y' - y x') - (g / l)(x^2 + y^2) / 2 (per unit mass),
  frequencies sqrt(g / l + Omega^2 sin^2 phi) -+ Omega sin(phi).
- `spinning_wheel`: a uniform disk spinning at rate s about its axis, pivoted on that axis a
  distance l below its centre and standing upright (the sleeping top). Its tilts (a, b)
  about the pivot, with the spin angle eliminated by Routh's procedure (spin momentum
  p = I3 s conserved), have the Routhian
  R = I1 (a'^2 cos^2 b + b'^2) / 2 + p a' sin(b) - m g l cos(a) cos(b),
  I1 the transverse inertia about the pivot (Huygens, `vibra.mechanics.rigid.parallel_axis`). Upright
  is unstable without spin (K = -m g l) and is stabilised by the gyroscopic coupling when
  p > 2 sqrt(I1 m g l) (Maxwell); frequencies (p -+ sqrt(p^2 - 4 I1 m g l)) / (2 I1).

Units: SI (kg, m, s, C, T, rad).
"""

from __future__ import annotations

import numpy as np
import sympy

from vibra._core import validate as _validate
from vibra.generalized import GeneralizedSystem
from vibra.mechanics.linearization import linearize
from vibra.mechanics.rigid import disk_inertia, parallel_axis

__all__ = ["charged_particle", "foucault_pendulum", "spinning_wheel"]


def charged_particle(mass: float = 1.0, omega0: float = 1.0, charge: float = 1.0, field: float = 1.0
                     ) -> GeneralizedSystem:
    """A charge in an isotropic 2-D well and a magnetic field along z: coordinates (x, y), in m.

    Parameters
    ----------
    mass : float
        m, in kg.
    omega0 : float
        Angular frequency of the well without field, in rad/s (stiffness m omega0^2 per axis).
    charge : float
        q, in C (any sign).
    field : float
        B along z, in T (any sign); omega_c = q B / m.

    Returns
    -------
    GeneralizedSystem
        M = m 1, K = m omega0^2 1, G = q B [[0, -1], [1, 0]].

    Raises
    ------
    TypeError
        A parameter that is not a real number.
    ValueError
        mass or omega0 not positive; charge or field not finite.

    Examples
    --------
    >>> modes = charged_particle(mass=1.0, omega0=1.0, charge=1.0, field=1.0).modes()
    >>> np.round(modes.natural_frequency, 12).tolist()   # sqrt(5)/2 -+ 1/2
    [0.61803398875, 1.61803398875]
    """
    m = _validate.positive_scalar(mass, "mass")
    w0 = _validate.positive_scalar(omega0, "omega0")
    q = _validate.real_scalar(charge, "charge")
    B = _validate.real_scalar(field, "field")
    x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    m_s, w_s, qB = sympy.symbols("m omega0 qB")
    L = m_s * (xd**2 + yd**2) / 2 - m_s * w_s**2 * (x**2 + y**2) / 2 + qB * (x * yd - y * xd) / 2
    return linearize(lagrangian=L, q=[x, y], qd=[xd, yd], q0=[0.0, 0.0], values={m_s: m, w_s: w0, qB: q * B},
                     name="charged particle")


def foucault_pendulum(length: float = 67.0, latitude: float = np.radians(48.85), g: float = 9.81,
                      rotation: float = 7.2921159e-5) -> GeneralizedSystem:
    """The Foucault pendulum: small swings (x, y) of the bob, in m, in the planet's frame.

    Parameters
    ----------
    length : float
        l, in m (67 m: the Pantheon's pendulum).
    latitude : float
        phi, in rad (Paris by default; negative in the southern hemisphere).
    g : float
        Gravitational acceleration, in m/s^2.
    rotation : float
        The planet's sidereal angular velocity Omega, in rad/s (the Earth's by default).

    Returns
    -------
    GeneralizedSystem
        Per unit mass: M = 1, K = (g / l) 1, G = 2 Omega sin(phi) [[0, -1], [1, 0]]. The swing
        plane turns at -Omega sin(phi), half the difference of the two frequencies.

    Raises
    ------
    TypeError
        A parameter that is not a real number.
    ValueError
        length or g not positive; latitude outside [-pi/2, pi/2]; rotation not finite.

    Examples
    --------
    >>> modes = foucault_pendulum().modes()
    >>> hours = 2 * np.pi / (np.diff(modes.natural_frequency)[0] / 2) / 3600   # precession period
    >>> round(float(hours), 2)
    31.79
    """
    l_value = _validate.positive_scalar(length, "length")
    phi = _validate.real_scalar(latitude, "latitude")
    if not abs(phi) <= np.pi / 2:
        raise ValueError(f"latitude is {phi!r} rad; it must lie in [-pi/2, pi/2]")
    gravity = _validate.positive_scalar(g, "g")
    rate = _validate.real_scalar(rotation, "rotation")
    x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    vertical, stiffness = sympy.symbols("Omega_z k")
    L = (xd**2 + yd**2) / 2 + vertical * (x * yd - y * xd) - stiffness * (x**2 + y**2) / 2
    return linearize(lagrangian=L, q=[x, y], qd=[xd, yd], q0=[0.0, 0.0],
                     values={vertical: rate * np.sin(phi), stiffness: gravity / l_value}, name="Foucault pendulum")


def spinning_wheel(mass: float = 2.0, radius: float = 0.3, height: float = 0.2, spin: float = 50.0, *,
                   g: float = 9.81) -> GeneralizedSystem:
    """An upright spinning disk on a pivot below its centre (the sleeping top): tilts (a, b), in rad.

    Parameters
    ----------
    mass : float
        m, in kg.
    radius : float
        The disk's radius, in m.
    height : float
        l, the distance from the pivot up to the disk's centre along its axis, in m.
    spin : float
        s, the spin rate about the axis, in rad/s (any sign).
    g : float
        Gravitational acceleration, in m/s^2.

    Returns
    -------
    GeneralizedSystem
        From the Routhian in the module docstring: M = I1 1 (I1 = m r^2 / 4 + m l^2),
        G = I3 s [[0, 1], [-1, 0]] (I3 = m r^2 / 2), K = -m g l 1 (upright is unstable
        without spin).

    Raises
    ------
    TypeError
        A parameter that is not a real number.
    ValueError
        mass, radius, height or g not positive; spin not finite.

    Examples
    --------
    >>> modes = spinning_wheel(spin=50.0).modes()
    >>> bool(modes.stable), np.round(modes.natural_frequency, 6).tolist()
    (True, [0.894212, 35.105788])
    """
    m = _validate.positive_scalar(mass, "mass")
    r = _validate.positive_scalar(radius, "radius")
    l_value = _validate.positive_scalar(height, "height")
    s = _validate.real_scalar(spin, "spin")
    gravity = _validate.positive_scalar(g, "g")
    about_pivot = parallel_axis(disk_inertia(m, r), m, [0.0, 0.0, l_value])
    transverse, axial = float(about_pivot[0, 0]), float(about_pivot[2, 2])
    a, b, ad, bd = sympy.symbols("a b a_dot b_dot")
    I1, p, mgl = sympy.symbols("I1 p mgl")
    routhian = I1 * (ad**2 * sympy.cos(b) ** 2 + bd**2) / 2 + p * ad * sympy.sin(b) - mgl * sympy.cos(a) * sympy.cos(b)
    return linearize(lagrangian=routhian, q=[a, b], qd=[ad, bd], q0=[0.0, 0.0],
                     values={I1: transverse, p: axial * s, mgl: m * gravity * l_value}, name="spinning wheel")
