"""The compiled loops of `vibra.dynamics` (numba): forces, kicks, the Nosé-Hoover chain, the step loop.

Everything here works in place on float64 arrays over the free degrees of freedom:

- `forces_into`: the forces of bonds (a bond b joins dofs i and j, the ghost index n standing
  for a wall at rest; V_b(d) = k_b d^2 / 2 + alpha_b d^3 / 3 + beta_b d^4 / 4 with
  d = x_j - x_i), which carry a 1-D spring system's K and `vibra.dynamics.fput`'s anharmonic
  springs, minus K_rest x for the rest of K (CSR). Positions and forces have a ghost entry n.
- `isokinetic_kick`: the exact flow of v' = F / m - mu v, mu = F.v / (v.M v), at fixed
  positions over a time h (Zhang 1997; Minary, Martyna and Tuckerman 2003).
- `nose_hoover_chain`: the symmetric Trotter half-step of a Nosé-Hoover chain (Martyna, Klein
  and Tuckerman 1992; Martyna, Tuckerman, Tobias and Klein 1996) over a time h.
- `run`: steps first..last of a run of a composition scheme (kick coefficients `kicks`, drift
  coefficients `drifts`; see `vibra.dynamics.schemes`), recording every `record_every` steps;
  `integrate` calls it over consecutive chunks of the run (`vibra.dynamics.cost.chunk_steps`),
  which return to Python, and again with ``check`` over a chunk that ended outside the finite
  numbers, to name the step where it left them.
"""

from __future__ import annotations

import math

import numba

__all__ = ["NONE", "ISOKINETIC", "NOSE_HOOVER", "forces_into", "isokinetic_kick", "nose_hoover_chain", "run"]

#: Thermostat kinds understood by `run`.
NONE, ISOKINETIC, NOSE_HOOVER = 0, 1, 2


@numba.njit(cache=True, nogil=True)
def forces_into(x, indptr, indices, data, bond_i, bond_j, bond_k, bond_alpha, bond_beta, out):  # pragma: no cover
    """out[:n] = the bond forces - K_rest x for one configuration x.

    x and out have n + 1 entries: index n is the wall, a ghost dof held at 0 (out[n] is
    scratch). A bond b has V_b(d) = k_b d^2 / 2 + alpha_b d^3 / 3 + beta_b d^4 / 4 with
    d = x[j_b] - x[i_b]; K_rest (CSR over the n dofs) is the part of K no bond carries.
    """
    n = x.shape[0] - 1
    for r in range(n + 1):
        out[r] = 0.0
    for b in range(bond_i.shape[0]):
        i = bond_i[b]
        j = bond_j[b]
        d = x[j] - x[i]
        slope = (bond_k[b] + (bond_alpha[b] + bond_beta[b] * d) * d) * d      # dV_b/dd
        out[i] += slope
        out[j] -= slope
    if data.shape[0]:
        for r in range(n):
            total = 0.0
            for p in range(indptr[r], indptr[r + 1]):
                total += data[p] * x[indices[p]]
            out[r] -= total


@numba.njit(cache=True, nogil=True)
def isokinetic_kick(v, force, masses, h, two_kinetic):  # pragma: no cover
    """v <- the exact isokinetic velocity flow over h at fixed force, then v scaled to
    sum m v^2 = two_kinetic (a change of a few ulps: it removes the rounding drift only).

    With a = F.v0 / (v0.M v0) and b = F.M^-1 F / (v0.M v0), the flow is
    v(h) = (v0 + M^-1 F s(h)) / s'(h), s = a (cosh(sqrt(b) h) - 1) / b + sinh(sqrt(b) h) / sqrt(b),
    which keeps v.M v exactly: s'^2 = 1 + 2 a s + b s^2.
    """
    n = v.shape[0]
    mv2 = 0.0
    fv = 0.0
    ff = 0.0
    for i in range(n):
        mv2 += masses[i] * v[i] * v[i]
        fv += force[i] * v[i]
        ff += force[i] * force[i] / masses[i]
    a = fv / mv2
    b = ff / mv2
    if b > 0.0:
        root = math.sqrt(b)
        x = root * h
        half = math.sinh(0.5 * x)
        sh = math.sinh(x)
        s = a * 2.0 * half * half / b + sh / root
        sdot = a * sh / root + math.cosh(x)
    else:
        s = h
        sdot = 1.0
    mv2 = 0.0
    for i in range(n):
        v[i] = (v[i] + force[i] / masses[i] * s) / sdot
        mv2 += masses[i] * v[i] * v[i]
    scale = math.sqrt(two_kinetic / mv2)
    for i in range(n):
        v[i] *= scale


@numba.njit(cache=True, nogil=True)
def _chain_force(j, two_kinetic, xi, Q, kT, n_f):  # pragma: no cover
    if j == 0:
        return (two_kinetic - n_f * kT) / Q[0]
    return (Q[j - 1] * xi[j - 1] * xi[j - 1] - kT) / Q[j]


@numba.njit(cache=True, nogil=True)
def _chain_kick(j, two_kinetic, xi, Q, kT, n_f, half, quarter):  # pragma: no cover
    """xi_j over h / 2 (`half`): the last thermostat kicked, any other scaled by xi_{j+1} over h / 4 either side."""
    g = _chain_force(j, two_kinetic, xi, Q, kT, n_f)
    if j == xi.shape[0] - 1:
        xi[j] += half * g
    else:
        f = math.exp(-quarter * xi[j + 1])
        xi[j] = (xi[j] * f + half * g) * f


@numba.njit(cache=True, nogil=True)
def nose_hoover_chain(v, masses, xi, eta, Q, kT, n_f, h):  # pragma: no cover
    """The chain's flow over h (a symmetric sweep: xi_M .. xi_1, eta and v, xi_1 .. xi_M)."""
    n = v.shape[0]
    chain = xi.shape[0]
    two_kinetic = 0.0
    for i in range(n):
        two_kinetic += masses[i] * v[i] * v[i]
    half = 0.5 * h
    quarter = 0.25 * h
    for j in range(chain - 1, -1, -1):
        _chain_kick(j, two_kinetic, xi, Q, kT, n_f, half, quarter)
    for j in range(chain):
        eta[j] += h * xi[j]
    scale = math.exp(-h * xi[0])
    for i in range(n):
        v[i] *= scale
    two_kinetic *= scale * scale
    for j in range(chain):
        _chain_kick(j, two_kinetic, xi, Q, kT, n_f, half, quarter)


@numba.njit(cache=True, nogil=True)
def _finite_state(x, v, force, masses, xi, eta, n):  # pragma: no cover
    """Whether every dof's m v^2 and x F are finite numbers (so x, v and F are, and their energies
    unless a sum overflows), and the thermostat's variables."""
    for i in range(n):
        if not (math.isfinite(masses[i] * v[i] * v[i]) and math.isfinite(x[i] * force[i])
                and math.isfinite(x[i]) and math.isfinite(force[i])):
            return False
    for j in range(xi.shape[0]):
        if not (math.isfinite(xi[j]) and math.isfinite(eta[j])):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def run(x, v, masses, indptr, indices, data, bond_i, bond_j, bond_k, bond_alpha, bond_beta,
        kicks, drifts, kind, kT, n_f, Q, xi, eta, two_kinetic, dt, n_steps, record_every,
        rec_x, rec_v, rec_state, force, carry, first, last, check):  # pragma: no cover
    """Advance (x, v) and the thermostat (xi, eta) in place over steps first..last (1-based,
    inclusive) of a run of n_steps; fill the record rows of those steps.

    Without a thermostat or with the isokinetic one, a step is the composition
    K(kicks[0] dt) D(drifts[0] dt) K(kicks[1] dt) ... D(drifts[-1] dt) K(kicks[-1] dt).
    With the Nosé-Hoover chain, `drifts` holds the weights w of symmetric sub-steps
    NHC(w dt / 2) K(w dt / 2) D(w dt) K(w dt / 2) NHC(w dt / 2) (one weight: velocity Verlet).

    The run may be cut into calls over consecutive ranges (chunks): `force` ((n + 1,), the
    forces at x) and `carry` ((1,), the kick pending from the last step) hold what one call
    leaves to the next, so that the chunks do exactly the arithmetic of one call over 1..n_steps
    (the call with first == 1 computes the first forces and records the initial state). With
    `check`, the call stops after the first step whose state is not finite (`_finite_state`:
    x, v, the forces at x, which go first where the last kick of a step is still pending, each
    dof's m v^2 and x F, xi, eta) and returns that step's number; it returns 0 otherwise.
    """
    n = v.shape[0]                                    # x and force carry the wall's ghost entry n
    chain = xi.shape[0]
    inverse_mass = 1.0 / masses
    pending = carry[0]
    if first == 1:
        pending = kicks[0]
        forces_into(x, indptr, indices, data, bond_i, bond_j, bond_k, bond_alpha, bond_beta, force)
        rec_x[0] = x[:n]
        rec_v[0] = v
        for j in range(chain):
            rec_state[0, j] = xi[j]
            rec_state[0, chain + j] = eta[j]
    row = (first - 1) // record_every
    for step in range(first, last + 1):
        if kind == NOSE_HOOVER:
            for w in drifts:
                h = w * dt
                nose_hoover_chain(v, masses, xi, eta, Q, kT, n_f, 0.5 * h)
                for i in range(n):
                    v[i] += 0.5 * h * force[i] / masses[i]
                for i in range(n):
                    x[i] += h * v[i]
                forces_into(x, indptr, indices, data, bond_i, bond_j, bond_k, bond_alpha, bond_beta, force)
                for i in range(n):
                    v[i] += 0.5 * h * force[i] / masses[i]
                nose_hoover_chain(v, masses, xi, eta, Q, kT, n_f, 0.5 * h)
        elif kind == ISOKINETIC:
            for s in range(drifts.shape[0]):
                isokinetic_kick(v, force, masses, kicks[s] * dt, two_kinetic)
                h = drifts[s] * dt
                for i in range(n):
                    x[i] += h * v[i]
                forces_into(x, indptr, indices, data, bond_i, bond_j, bond_k, bond_alpha, bond_beta, force)
            isokinetic_kick(v, force, masses, kicks[drifts.shape[0]] * dt, two_kinetic)
        else:
            # Plain kicks at fixed x add up: the last kick of a step and the first of the next run
            # as one pass (first same as last), except where the step is recorded or the run ends.
            for s in range(drifts.shape[0]):
                hk = (pending if s == 0 else kicks[s]) * dt
                h = drifts[s] * dt
                for i in range(n):                      # kick and drift in one pass
                    v[i] += hk * force[i] * inverse_mass[i]
                    x[i] += h * v[i]
                forces_into(x, indptr, indices, data, bond_i, bond_j, bond_k, bond_alpha, bond_beta, force)
            if step % record_every == 0 or step == n_steps:
                hk = kicks[drifts.shape[0]] * dt
                for i in range(n):
                    v[i] += hk * force[i] * inverse_mass[i]
                pending = kicks[0]
            else:
                pending = kicks[drifts.shape[0]] + kicks[0]
        if step % record_every == 0:
            row += 1
            rec_x[row] = x[:n]
            rec_v[row] = v
            for j in range(chain):
                rec_state[row, j] = xi[j]
                rec_state[row, chain + j] = eta[j]
        if check and not _finite_state(x, v, force, masses, xi, eta, n):
            carry[0] = pending
            return step
    carry[0] = pending
    return 0
