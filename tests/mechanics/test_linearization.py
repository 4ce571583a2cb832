"""linearize beyond T and V (issue 15, items 3-5): Lagrangians, Rayleigh dissipation, sympy.physics.mechanics.

Truth: sympy.physics.mechanics' own linearizer (LagrangesMethod.linearize, KanesMethod.linearize:
an independent symbolic derivation), closed forms, and seed 000 problem III.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy
from sympy.physics.mechanics import (
    KanesMethod, LagrangesMethod, Lagrangian, Particle, Point, ReferenceFrame, dynamicsymbols,
)

from vibra.mechanics.linearization import linearize

EPS = float(np.finfo(float).eps)


def _numeric(matrix, values):
    return np.array(sympy.N(sympy.Matrix(matrix).subs(values), 30).tolist(), dtype=float)


def _state_matrix(system):
    """[[0, I], [-M^-1 K, -M^-1 (G + C)]] of a GeneralizedSystem."""
    n = system.n_dof
    D = np.zeros((n, n))
    for part in (system.G, system.C):
        if part is not None:
            D = D + part
    inverse = np.linalg.inv(system.M)
    return np.block([[np.zeros((n, n)), np.eye(n)], [-inverse @ system.K, -inverse @ D]])


def _damped_double_pendulum():
    q1, q2 = dynamicsymbols("q1 q2")
    m1, m2, l1, l2, g, c = sympy.symbols("m1 m2 l1 l2 g c", positive=True)
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P1 = O.locatenew("P1", l1 * (sympy.sin(q1) * N.x - sympy.cos(q1) * N.y))
    P1.set_vel(N, P1.pos_from(O).dt(N))
    P2 = P1.locatenew("P2", l2 * (sympy.sin(q2) * N.x - sympy.cos(q2) * N.y))
    P2.set_vel(N, P2.pos_from(O).dt(N))
    a, b = Particle("a", P1, m1), Particle("b", P2, m2)
    a.potential_energy = m1 * g * P1.pos_from(O).dot(N.y)
    b.potential_energy = m2 * g * P2.pos_from(O).dot(N.y)
    # A viscous drag on the lower bob: a damping force, in the force list.
    method = LagrangesMethod(Lagrangian(N, a, b), [q1, q2], forcelist=[(P2, -c * P2.vel(N))], frame=N)
    method.form_lagranges_equations()
    return method, [q1, q2], (m1, m2, l1, l2, g, c)


@pytest.mark.parametrize("numbers", [(1.0, 1.0, 1.0, 1.0, 9.81, 0.3), (1e-3, 1e3, 1.0, 1e-3, 9.81, 2.0)])
def test_lagranges_method_matches_sympys_linearizer(numbers):
    method, coordinates, symbols = _damped_double_pendulum()
    values = dict(zip(symbols, numbers))
    system = linearize(method, q0=[0.0, 0.0], values=values)
    assert system.C is not None and system.G is None
    rates = [q.diff(dynamicsymbols._t) for q in coordinates]
    op = {**{q: 0 for q in coordinates}, **{r: 0 for r in rates}}
    A, _, _ = method.linearize(q_ind=coordinates, qd_ind=rates, op_point=op, A_and_B=True)
    reference = _numeric(A, values)
    ours = _state_matrix(system)
    assert np.abs(ours - reference).max() <= 1e-14 * np.abs(reference).max()


def test_kanes_method_in_a_rotating_frame():
    # A particle on a spring in a frame turning at rate W about z, with drag relative to the frame:
    # gyroscopic (Coriolis) and damping terms together. Truth: the textbook rotating-frame
    # equations m x'' = -k1 x + m W^2 x + 2 m W y' - c x' (and y), and the Jacobian of Kane's
    # forcing vector taken by sympy. (sympy 1.14's KanesMethod.linearize returns a different
    # stiffness here, -k1 + 2 m W^2: its linearizer does not handle the frame's explicit
    # dependence on t; the Lagrange test above and the chain below compare with it.)
    x, y = dynamicsymbols("x y")
    u1, u2 = dynamicsymbols("u1 u2")
    m, k1, k2, c, W = sympy.symbols("m k1 k2 c W", positive=True)
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [W * dynamicsymbols._t, N.z])
    B.set_ang_vel(N, W * N.z)
    O = Point("O")
    O.set_vel(N, 0)
    O.set_vel(B, 0)
    P = O.locatenew("P", x * B.x + y * B.y)
    P.set_vel(B, u1 * B.x + u2 * B.y)
    P.v1pt_theory(O, N, B)
    particle = Particle("p", P, m)
    loads = [(P, -k1 * x * B.x - k2 * y * B.y - c * (u1 * B.x + u2 * B.y))]
    kane = KanesMethod(N, q_ind=[x, y], u_ind=[u1, u2], kd_eqs=[x.diff() - u1, y.diff() - u2])
    kane.kanes_equations([particle], loads)
    values = {m: 2.0, k1: 30.0, k2: 50.0, c: 0.4, W: 1.5}
    system = linearize(kane, q0=[0.0, 0.0], values=values)
    np.testing.assert_allclose(system.G, 2 * 2.0 * 1.5 * np.array([[0.0, -1.0], [1.0, 0.0]]), rtol=1e-15)
    np.testing.assert_allclose(system.C, 0.4 * np.eye(2), rtol=1e-15)
    np.testing.assert_allclose(system.K, np.diag([30.0 - 2.0 * 1.5**2, 50.0 - 2.0 * 1.5**2]), rtol=1e-15)
    op = {x: 0, y: 0, u1: 0, u2: 0}
    forcing = kane.forcing
    stiffness = -_numeric(forcing.jacobian([x, y]).subs(op), values)
    velocity = -_numeric(forcing.jacobian([u1, u2]).subs(op), values)
    np.testing.assert_allclose(system.K, stiffness, rtol=1e-15)
    np.testing.assert_allclose(system.G + system.C, velocity, rtol=1e-15)


def test_kanes_method_matches_sympys_linearizer():
    # Two masses, three springs and two dampers (non-proportional), by Kane's method.
    x1, x2 = dynamicsymbols("x1 x2")
    u1, u2 = dynamicsymbols("u1 u2")
    m1, m2, k1, k2, k3, c1, c2 = sympy.symbols("m1 m2 k1 k2 k3 c1 c2", positive=True)
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P1, P2 = O.locatenew("P1", x1 * N.x), O.locatenew("P2", x2 * N.x)
    P1.set_vel(N, u1 * N.x)
    P2.set_vel(N, u2 * N.x)
    loads = [(P1, (-k1 * x1 + k2 * (x2 - x1) - c1 * u1 + c2 * (u2 - u1)) * N.x),
             (P2, (-k2 * (x2 - x1) - k3 * x2 - c2 * (u2 - u1)) * N.x)]
    kane = KanesMethod(N, q_ind=[x1, x2], u_ind=[u1, u2], kd_eqs=[x1.diff() - u1, x2.diff() - u2])
    kane.kanes_equations([Particle("a", P1, m1), Particle("b", P2, m2)], loads)
    values = {m1: 1e-3, m2: 1e3, k1: 1.0, k2: 1e6, k3: 2.0, c1: 0.5, c2: 3.0}
    system = linearize(kane, q0=[0.0, 0.0], values=values)
    A, _, _ = kane.linearize(op_point={x1: 0, x2: 0, u1: 0, u2: 0}, A_and_B=True)
    reference = _numeric(A, values)
    assert np.abs(_state_matrix(system) - reference).max() <= 1e-14 * np.abs(reference).max()


def test_kanes_method_with_other_speeds_is_refused():
    x = dynamicsymbols("x")
    u = dynamicsymbols("u")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, 2 * u * N.x)
    kane = KanesMethod(N, q_ind=[x], u_ind=[u], kd_eqs=[x.diff() - 2 * u])
    kane.kanes_equations([Particle("p", P, 1)], [(P, -x * N.x)])
    with pytest.raises(ValueError, match=r"the KanesMethod's speeds are not the coordinates' rates"):
        linearize(kane, q0=[0.0])
    fresh = KanesMethod(N, q_ind=[x], u_ind=[u], kd_eqs=[x.diff() - u])
    with pytest.raises(ValueError, match=r"the KanesMethod has no equations yet"):
        linearize(fresh, q0=[0.0])


def test_lagranges_method_validation():
    method, coordinates, symbols = _damped_double_pendulum()
    values = dict(zip(symbols, (1.0, 1.0, 1.0, 1.0, 9.81, 0.3)))
    with pytest.raises(ValueError, match=r"q0 is not an equilibrium: the forcing vector"):
        linearize(method, q0=[0.3, 0.0], values=values)
    with pytest.raises(ValueError, match=r"V is given with a LagrangesMethod"):
        linearize(method, sympy.Integer(0), q0=[0.0, 0.0], values=values)
    frame, particle, coordinate = _frame_particle()
    unformed = LagrangesMethod(Lagrangian(frame, particle), [coordinate])
    with pytest.raises(ValueError, match=r"the LagrangesMethod has no equations yet"):
        linearize(unformed, q0=[0.0])


def _frame_particle():
    q = dynamicsymbols("s")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    P.set_vel(N, q.diff() * N.x)
    particle = Particle("p", P, 1)
    particle.potential_energy = q**2 / 2
    return N, particle, q


def test_circulatory_forces_are_refused():
    x, y = dynamicsymbols("x y")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, x.diff() * N.x + y.diff() * N.y)
    particle = Particle("p", P, 1)
    # A follower-type force (-x + 0.5 y, -y): its stiffness matrix is not symmetric.
    method = LagrangesMethod(Lagrangian(N, particle), [x, y], forcelist=[(P, (-x + 0.5 * y) * N.x - y * N.y)], frame=N)
    method.form_lagranges_equations()
    with pytest.raises(ValueError, match=r"the position forces are not conservative at q0"):
        linearize(method, q0=[0.0, 0.0])


def test_rayleigh_dissipation_gives_C():
    x, xd = sympy.symbols("x x_dot")
    m, k, c = 2.0, 8.0, 0.4
    system = linearize(m * xd**2 / 2, k * x**2 / 2, [x], [xd], [0.0], dissipation=c * xd**2 / 2)
    np.testing.assert_array_equal(system.C, [[c]])
    modes = system.modes()
    zeta = c / (2 * np.sqrt(k * m))
    np.testing.assert_allclose(modes.damping_ratio, [zeta], rtol=1e-15)
    np.testing.assert_allclose(modes.natural_frequency, [2.0], rtol=1e-15)
    with pytest.raises(ValueError, match=r"the dissipation R is not positive semi-definite at q0"):
        linearize(m * xd**2 / 2, k * x**2 / 2, [x], [xd], [0.0], dissipation=-xd**2)
    with pytest.raises(TypeError, match=r"dissipation must be a sympy expression, got a str"):
        linearize(m * xd**2 / 2, k * x**2 / 2, [x], [xd], [0.0], dissipation="x_dot**2")


def test_lagrangian_keyword_and_its_messages():
    x, xd = sympy.symbols("x x_dot")
    system = linearize(lagrangian=xd**2 / 2 - 4 * x**2 / 2, q=[x], qd=[xd], q0=[0.0])
    assert system.G is None and system.C is None
    np.testing.assert_allclose(system.modes().omega, [2.0], rtol=1e-15)
    with pytest.raises(ValueError, match=r"give either lagrangian=L or T and V, not both"):
        linearize(xd**2 / 2, x**2 / 2, [x], [xd], [0.0], lagrangian=xd**2 / 2)
    with pytest.raises(ValueError, match=r"give T and V \(kinetic and potential energy\), or lagrangian=L"):
        linearize(xd**2 / 2, q=[x], qd=[xd], q0=[0.0])
    with pytest.raises(ValueError, match=r"q, qd and q0 are needed"):
        linearize(lagrangian=xd**2 / 2, q=[x], qd=[xd])
    with pytest.raises(TypeError, match=r"lagrangian must be a sympy expression"):
        linearize(lagrangian=[xd], q=[x], qd=[xd], q0=[0.0])


def test_docs_generalized_runs_as_written(tmp_path, monkeypatch):
    # docs/generalized.md must work exactly as written: its python blocks, in order, in a scratch folder.
    import re
    import warnings
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "generalized.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 8
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for block in blocks:
            exec(compile(block, "docs/generalized.md", "exec"), namespace)
    # The numbers the docs state.
    np.testing.assert_allclose(namespace["modes"].natural_frequency, np.sqrt(9 + 9 / 4) + np.array([-1.5, 1.5]),
                               rtol=1e-14)
    np.testing.assert_allclose(namespace["critical"].damping_ratio - 1, [1e-12], rtol=1e-3)
