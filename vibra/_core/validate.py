"""Input checks shared by the public functions.

Each check takes the argument's public ``name`` and raises an error that names it, states
the requirement and shows what arrived (STYLE.md, "Validation names the offending input").
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray



class ArgumentError(ValueError):
    """A bad value that names the public argument at fault by construction (`argument`: the root
    of the name, ``"positions"`` for ``positions[3,1]``), so a caller that gave the argument
    another name (a scene key) maps it without reading the message.

    Attributes
    ----------
    argument : str
        The argument's public name.
    """

    def __init__(self, argument: str, message: str) -> None:
        super().__init__(message)
        self.argument = argument


def argument_of(name: str) -> str:
    """The argument an input's name belongs to: ``"name_or_atoms"`` for ``"name_or_atoms.positions[1]"``."""
    return name.split("[", 1)[0].split(".", 1)[0]


# Relative tolerance of the symmetry check: |K_ij - K_ji| <= SYMMETRY_RTOL * max|K|.
# Assembly in floating point leaves gaps of a few ulps; a user's typo leaves far more.
SYMMETRY_RTOL = 1e-10


def _scalar(value: Any) -> str:
    """A numpy scalar as the plain Python repr a user typed (-2.0, nan, inf)."""
    return repr(value.item()) if hasattr(value, "item") else repr(value)


def real_scalar(value: Any, name: str) -> float:
    """`value` (a Python or numpy real number, or a 0-d array) as a finite float."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        array = np.asarray(value) if not isinstance(value, str) else None
        if array is None or array.ndim != 0 or not np.issubdtype(array.dtype, np.number):
            raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
        if array.dtype.kind == "c":
            raise TypeError(f"{name} must be a real number, got the complex {value!r}")
        value = array.item()
    number = float(value)
    if not np.isfinite(number):
        raise ValueError(f"{name} is {number!r}; it must be finite")
    return number


def positive_scalar(value: Any, name: str, what: str | None = None) -> float:
    """`value` as a finite float > 0; `what` names the quantity in the message ("a mass ...")."""
    number = real_scalar(value, name)
    if not number > 0:
        subject = f"a {what}" if what else "it"
        raise ValueError(f"{name} is {number!r}; {subject} must be positive and finite")
    return number


def increasing_times(t: Any, name: str = "t") -> NDArray[np.float64]:
    """(n_t,) strictly increasing finite times, n_t >= 2."""
    times = real_array(t, name, ndim=1)
    if times.shape[0] < 2:
        raise ValueError(f"{name} must hold at least 2 times, got {times.shape[0]}")
    step = np.diff(times)
    if not (step > 0).all():
        i = int(np.argmax(~(step > 0)))
        raise ValueError(f"{name} must increase: {name}[{i + 1}] = {float(times[i + 1])!r} <= "
                         f"{name}[{i}] = {float(times[i])!r}")
    return times


def real_numbers(value: Any, name: str) -> NDArray[np.float64]:
    """`value` as a float64 ndarray of any shape, NaN and inf allowed; complex, text, None refused."""
    if sp.issparse(value):
        raise TypeError(f"{name} must be a dense array here, got a scipy.sparse matrix")
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be real numbers, got {value!r}")
    return _float_array(value, name)


def complex_array(value: Any, name: str, *, ndim: int) -> NDArray[np.complex128]:
    """`value` as a finite complex128 ndarray of `ndim` dimensions (real input allowed)."""
    raw = np.asarray(value) if not isinstance(value, (str, bytes)) and value is not None else None
    if raw is None or raw.dtype.kind not in "iufc" or (raw.dtype.kind == "b"):
        raise TypeError(f"{name} must be an array of real or complex numbers, got {type(value).__name__}"
                        + (f" of {raw.dtype}" if raw is not None else ""))
    array = np.asarray(raw, dtype=complex)
    if array.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got shape {array.shape}")
    finite(array, name)
    return array


def real_array(value: Any, name: str, *, ndim: int | tuple[int, ...] | None = None) -> NDArray[np.float64]:
    """`value` as a finite float64 ndarray; raise naming `name` otherwise."""
    if sp.issparse(value):
        raise TypeError(f"{name} must be a dense array here, got a scipy.sparse matrix")
    array = _float_array(value, name)
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else ndim
        if array.ndim not in allowed:
            want = " or ".join(f"{d}-D" for d in allowed)
            raise ValueError(f"{name} must be {want}, got shape {array.shape}")
    finite(array, name)
    return array


def _float_array(value: Any, name: str) -> NDArray[np.float64]:
    """`value` as a float64 ndarray (no copy when it is one); complex, text and bool refused.

    ``np.asarray(z, dtype=float)`` silently drops the imaginary part of a complex array and
    parses strings such as "1.5": both are refused here, naming `name` and what arrived.
    """
    raw = value if isinstance(value, np.ndarray) else None
    if raw is None:
        if isinstance(value, (str, bytes)) or value is None or isinstance(value, (dict, set)):
            raise TypeError(f"{name} must be an array of real numbers, got {type(value).__name__}")
        try:
            raw = np.asarray(value)
        except (TypeError, ValueError):
            raise TypeError(
                f"{name} must be an array of real numbers, got {type(value).__name__}"
            ) from None
    kind = raw.dtype.kind
    if kind == "c":
        raise TypeError(f"{name} must be real, got a complex array ({raw.dtype}); pass the real part "
                        "explicitly if the imaginary part is meant to be dropped")
    if kind in "USV":
        raise TypeError(f"{name} must be an array of real numbers, got {type(value).__name__} of text ({raw.dtype})")
    if kind == "b":
        raise TypeError(f"{name} must be real numbers, got {'a bool array' if raw.ndim else repr(value)}")
    if kind == "O":
        items = [item for item in raw.flat]
        if any(isinstance(item, (bool, np.bool_, str, bytes, complex, np.complexfloating)) or item is None
               for item in items):
            bad = next(item for item in items if isinstance(item, (bool, np.bool_, str, bytes, complex,
                                                                    np.complexfloating)) or item is None)
            raise TypeError(f"{name} must be an array of real numbers, got an entry {bad!r} "
                            f"({type(bad).__name__})")
    try:
        return np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"{name} must be an array of real numbers, got {type(value).__name__}"
        ) from None


def finite(array: NDArray[Any], name: str) -> None:
    """Raise if `array` holds NaN or inf, giving the first offending index."""
    if array.dtype.kind == "f" and array.size > 4096:
        with np.errstate(all="ignore"):
            if np.isfinite(np.sum(array)):  # a finite sum has no NaN or inf: no n-sized mask needed
                return
    bad = ~np.isfinite(array)
    _refuse_first(bad, array, name, "every entry must be finite")


def _refuse_first(bad: NDArray[np.bool_], array: NDArray[np.float64], name: str, rule: str) -> None:
    """Raise `ArgumentError` naming the first entry of `array` where `bad` holds, and the `rule` it breaks."""
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = ",".join(str(i) for i in index)
        raise ArgumentError(argument_of(name), f"{name}[{where}] is {_scalar(array[index])}; {rule}")


def positive(array: NDArray[np.float64], name: str, what: str = "value") -> None:
    """Raise if any entry of `array` is not strictly positive (and finite)."""
    finite(array, name)
    bad = ~(array > 0)
    _refuse_first(bad, array, name, f"every {what} must be positive and finite")


def nonnegative(array: NDArray[np.float64], name: str, what: str = "value") -> None:
    """Raise if any entry of `array` is negative or not finite."""
    finite(array, name)
    bad = array < 0
    _refuse_first(bad, array, name, f"every {what} must be >= 0")


def square_matrix(value: Any, name: str) -> NDArray[np.float64] | sp.csr_matrix:
    """`value` as a finite square float matrix, dense ndarray or CSR."""
    matrix = matrix_argument(value, name)
    if not sp.issparse(matrix):
        finite(matrix, name)
    return matrix


def matrix_argument(value: Any, name: str) -> NDArray[np.float64] | sp.csr_matrix:
    """`value` as a square float matrix, dense ndarray (never copied when already float64) or CSR.

    Kind and shape only, plus the finiteness of a sparse matrix's stored entries (O(nnz));
    a dense matrix's entries are checked by `finite` (call it after any size guard).
    """
    if sp.issparse(value):
        if value.dtype.kind == "c":
            raise TypeError(f"{name} must be real, got a complex sparse matrix ({value.dtype})")
        if value.dtype.kind not in "biuf":
            raise TypeError(f"{name} must be a matrix of real numbers, got a sparse matrix of {value.dtype}")
        matrix = sp.csr_matrix(value, dtype=float)
        finite(matrix.data, f"{name}.data")
    else:
        matrix = _float_array(value, name)
        if matrix.ndim != 2:
            raise ValueError(f"{name} must be 2-D, got shape {matrix.shape}")
    if matrix.shape[0] != matrix.shape[1]:
        raise ValueError(f"{name} must be square, got shape {matrix.shape}")
    if matrix.shape[0] == 0:
        raise ValueError(f"{name} must have at least one row, got shape {matrix.shape}")
    return matrix


def _dense_asymmetry(matrix: NDArray[np.float64]) -> tuple[float, int, int, float]:
    """(max |A_ij - A_ji|, i, j, max |A|) of a dense square A, in row blocks (no n x n temporary)."""
    n = matrix.shape[0]
    step = max(1, (1 << 21) // n)
    gap, i, j, scale = 0.0, 0, 0, 0.0
    for start in range(0, n, step):
        rows = matrix[start:start + step]
        difference = np.abs(rows - matrix[:, start:start + step].T)
        k = int(np.argmax(difference))
        r, c = divmod(k, n)
        if difference[r, c] > gap:
            gap, i, j = float(difference[r, c]), start + r, c
        scale = max(scale, float(np.abs(rows).max()))
    return gap, i, j, scale


def _sparse_asymmetry(matrix: Any) -> tuple[float, int, int, float]:
    """(max |A_ij - A_ji|, i, j, max |A|) of a sparse square A. A canonical CSR whose pattern is symmetric (every
    stiffness matrix here) is compared with its transpose entry by entry, whose pattern is then the same (3HSY's
    network: 2.5 against 9.7 ms by A - A^T, a sparse sum); any other, by that sum."""
    given = matrix if sp.issparse(matrix) and matrix.format == "csr" else sp.csr_matrix(matrix)
    if given.has_canonical_format:  # (no duplicates: the stored entries are the matrix's)
        scale = float(np.abs(given.data).max()) if given.nnz else 0.0
        flipped = given.T.tocsr()  # (sorted indices, no duplicates)
        if np.array_equal(given.indptr, flipped.indptr) and np.array_equal(given.indices, flipped.indices):
            difference = np.abs(np.subtract(given.data, flipped.data, out=flipped.data), out=flipped.data)  # (in place)
            k = int(np.argmax(difference)) if difference.size else 0
            if not difference.size or difference[k] == 0:
                return 0.0, 0, 0, scale
            row = int(np.searchsorted(given.indptr, k, side="right")) - 1
            return float(difference[k]), row, int(given.indices[k]), scale
    scale = float(abs(given).max()) if given.nnz else 0.0  # (duplicates summed)
    gaps = (given - given.T).tocoo()
    if not gaps.nnz:
        return 0.0, 0, 0, scale
    k = int(np.argmax(np.abs(gaps.data)))
    return float(abs(gaps.data[k])), int(gaps.row[k]), int(gaps.col[k]), scale


def boolean(value: Any, name: str) -> bool:
    """`value` as a bool: True, False or a numpy bool; anything else (1, "no", None) refused."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r} ({type(value).__name__})")
    return bool(value)


def text(value: Any, name: str) -> str:
    """`value` as a non-empty str."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str, got {value!r} ({type(value).__name__})")
    if not value.strip():
        raise ValueError(f"{name} is {value!r}; it must be a non-empty name")
    return value


def optional_limit(value: Any, name: str) -> float | None:
    """None, or a positive number (``float("inf")`` allowed: no limit)."""
    if value is None:
        return None
    if isinstance(value, (float, np.floating)) and np.isposinf(value):
        return float("inf")
    return positive_scalar(value, name)


def nonnegative_scalar(value: Any, name: str) -> float:
    """`value` as a finite float >= 0."""
    number = real_scalar(value, name)
    if number < 0:
        raise ValueError(f"{name} is {number!r}; it must be >= 0 and finite")
    return number


def positive_semidefinite(matrix: Any, name: str, *, rtol: float = 1e-10) -> None:
    """Raise if the symmetric `matrix` (dense or sparse) has an eigenvalue below -rtol * max|matrix|.

    The diagonal is checked first (a negative diagonal entry is a negative eigenvalue's
    witness); then a Cholesky factorisation of matrix + rtol * max|matrix| I decides, whose
    failure gives the smallest eigenvalue for the message (up to 2000 rows: dense; larger
    sparse matrices: the pivots of an unpivoted LDL^T, then Lanczos for the message).
    """
    is_sparse = sp.issparse(matrix)
    diagonal = np.asarray(matrix.diagonal(), dtype=float)
    bad = np.flatnonzero(diagonal < 0)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name}[{i},{i}] is {_scalar(diagonal[i])}; a damping matrix must have a non-negative "
                         f"diagonal and be positive semi-definite (no negative damping)")
    scale = float(abs(matrix).max()) if (not is_sparse or matrix.nnz) else 0.0
    if scale == 0:
        return
    n = matrix.shape[0]
    shift = rtol * scale
    if is_sparse and n > 2000:
        import scipy.sparse.linalg as sla   # here: scipy's sparse linear algebra costs 60 ms to import

        # LDL^T of C + shift I without pivoting: all pivots > 0 exactly when it is positive
        # definite (Sylvester's inertia), i.e. when C has no eigenvalue below -shift.
        shifted = (sp.csc_matrix(matrix) + shift * sp.identity(n, format="csc")).tocsc()
        try:
            pivots = sla.splu(shifted, diag_pivot_thresh=0.0, permc_spec="MMD_AT_PLUS_A",
                              options={"SymmetricMode": True}).U.diagonal()
            if (pivots > 0).all():
                return
        except RuntimeError:  # an exactly zero pivot: an eigenvalue at -shift
            pass
        start = np.random.default_rng(0).standard_normal(n)
        smallest = float(sla.eigsh(sp.csr_matrix(matrix), k=1, which="SA", v0=start, tol=1e-8)[0][0])
    else:
        dense = matrix.toarray() if is_sparse else matrix
        try:
            np.linalg.cholesky(dense + shift * np.eye(n))
            return
        except np.linalg.LinAlgError:
            smallest = float(np.linalg.eigvalsh(dense)[0])
    if smallest < -shift:
        raise ValueError(
            f"{name} is not positive semi-definite: its smallest eigenvalue is {smallest:.3g} "
            f"(< -{shift:.3g}); a damping matrix must have no negative eigenvalue (negative damping)"
        )


def symmetric(
    matrix: NDArray[np.float64] | sp.csr_matrix, name: str, *, symmetrize: bool = False,
    rtol: float = SYMMETRY_RTOL,
) -> NDArray[np.float64] | sp.csr_matrix:
    """Check symmetry within ``rtol * max|matrix|``; with `symmetrize`, return (A + A^T) / 2."""
    if isinstance(matrix, sp.spmatrix) or sp.issparse(matrix):
        gap, i, j, scale = _sparse_asymmetry(matrix)
    else:
        gap, i, j, scale = _dense_asymmetry(matrix)
    atol = rtol * scale
    if gap > atol:
        if not symmetrize:
            raise ValueError(
                f"{name} is not symmetric: |{name}[{i},{j}] - {name}[{j},{i}]| = {gap:.3g} > "
                f"atol={atol:.3g} ({rtol:g} * max|{name}|); pass symmetrize=True to use "
                f"({name} + {name}^T) / 2"
            )
    if gap > 0:  # within tolerance (a few ulps) or symmetrize=True
        matrix = (matrix + matrix.T) * 0.5
        if sp.issparse(matrix):
            matrix = sp.csr_matrix(matrix)
    return matrix


def site_positions(value: Any, n_dof: int, name: str = "positions") -> NDArray[np.float64]:
    """`value` as the (n_dof / 3, 3) finite coordinates of the sites of an n_dof-dof 3-D system (three
    dofs per site, site-major); raise naming `name` otherwise."""
    array = real_array(value, name, ndim=2)
    if n_dof % 3 or array.shape != (n_dof // 3, 3):
        raise ValueError(f"{name} must have shape (n_dof / 3, 3), one row per site of the {n_dof} dofs "
                         f"(three per site, site-major), got shape {array.shape}")
    return array


def mass_argument(value: Any, n_dof: int, name: str = "M") -> NDArray[np.float64]:
    """Masses as an (n_dof,) positive vector or an (n_dof, n_dof) SPD matrix."""
    if sp.issparse(value):
        matrix = sp.csr_matrix(value)
        diagonal = matrix.diagonal()
        off_diagonal = matrix.nnz - np.count_nonzero(diagonal)
        # A diagonal sparse M stays a vector (never densify n x n); a general one is dense.
        value = diagonal if off_diagonal == 0 and matrix.shape[0] == matrix.shape[1] else matrix.toarray()
    masses = real_array(value, name, ndim=(1, 2))
    if masses.ndim == 2 and masses.shape == (n_dof, n_dof) and not np.count_nonzero(masses - np.diag(np.diag(masses))):
        masses = np.diag(masses).copy()  # a diagonal M as a matrix: its masses (the diagonal-mass paths)
    if masses.ndim == 1:
        if masses.shape[0] != n_dof:
            raise ValueError(f"{name} must have {n_dof} masses to match K, got shape {masses.shape}")
        positive(masses, name, "mass")
        not_subnormal(masses, name)
        return masses
    if masses.shape != (n_dof, n_dof):
        raise ValueError(f"{name} must be ({n_dof}, {n_dof}) to match K, got shape {masses.shape}")
    masses = symmetric(masses, name)
    try:
        np.linalg.cholesky(masses)
    except np.linalg.LinAlgError:
        smallest = float(np.linalg.eigvalsh(masses)[0])
        raise ValueError(
            f"{name} is not positive definite (smallest eigenvalue {smallest:.3g}); a mass "
            "matrix must be symmetric positive definite"
        ) from None
    return masses


def count(value: Any, name: str, *, low: int, high: int) -> int:
    """An integer in [low, high]."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if not low <= value <= high:
        raise ValueError(f"{name} is {value}; expected {low} <= {name} <= {high}")
    return int(value)


def choice(value: Any, name: str, allowed: tuple[str, ...]) -> str:
    """One of the option strings in `allowed`."""
    if value not in allowed:
        options = ", ".join(repr(a) for a in allowed)
        raise ValueError(f"{name} is {value!r}; expected one of {options}")
    return str(value)


#: Smallest normal float64; a mass below it is subnormal and has lost digits already.
TINY = float(np.finfo(float).tiny)

#: Largest eigenvalue scale max|K| / min(m) that vibra accepts: omega^2 = 1e300 leaves room
#: for the products of a solver (K~ entries, norms, residuals) below float64's 1.8e308.
SCALE_LIMIT = 1e300


def not_subnormal(values: NDArray[np.float64], name: str) -> None:
    """Raise if a nonzero entry of `values` is subnormal (|x| < 2.2e-308): digits are already lost."""
    if values.size and (values.min() >= TINY or values.max() <= -TINY):
        return  # one sign, all normal: no n-sized temporaries
    small = (values != 0) & (np.abs(values) < TINY)
    if small.any():
        i = int(np.argmax(small))
        raise ValueError(f"{name}[{i}] is {_scalar(values.flat[i])}, a subnormal number (below {TINY:.3g}) "
                         "that has lost digits; rescale the units so that it is a normal float")


def eigenvalue_scale(stiffness_max: float, mass_min: float, k_name: str = "K", m_name: str = "M") -> None:
    """Raise if max|K| / min(m) (the scale of omega^2) would overflow or underflow float64.

    K entries near 1e300 with masses near 1e-300 give K~ = M^-1/2 K M^-1/2 entries of 1e600
    (inf); the reverse gives 1e-600 (0): both are refused with the figures instead.
    """
    if stiffness_max == 0 or mass_min == 0:
        return
    exponent = np.log10(stiffness_max) - np.log10(mass_min)
    if exponent > np.log10(SCALE_LIMIT):
        raise ValueError(
            f"max|{k_name}| / min({m_name}) is about 1e{exponent:.0f} (max|{k_name}| = {stiffness_max:.3g}, "
            f"min {m_name} = {mass_min:.3g}): omega^2 would overflow float64 (limit {SCALE_LIMIT:g}); "
            "rescale the units (e.g. stiffness in kN/m, masses in g)"
        )
    if exponent < -np.log10(SCALE_LIMIT):
        raise ValueError(
            f"max|{k_name}| / min({m_name}) is about 1e{exponent:.0f} (max|{k_name}| = {stiffness_max:.3g}, "
            f"min {m_name} = {mass_min:.3g}): omega^2 would underflow float64 (limit {1 / SCALE_LIMIT:g}); "
            "rescale the units"
        )


def min_count(value: Any, name: str, *, low: int, what: str) -> int:
    """An integer >= low; `what` names what needs it ("n is 1; a chain needs n >= 2")."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < low:
        raise ValueError(f"{name} is {value}; {what} needs {name} >= {low}")
    return int(value)


def real_values(value: Any, name: str) -> NDArray[np.float64]:
    """One real number (as a 0-d array) or a 1-D array; a bad scalar is named without an index."""
    if np.ndim(value) == 0:
        return np.asarray(real_scalar(value, name))
    return real_array(value, name, ndim=1)


def per_entry(value: Any, n: int, name: str, each: str = "") -> NDArray[np.float64]:
    """(n,) floats from one real number (every entry) or a 1-D array of `n`; `each` says what one
    entry belongs to in the message (``"site"``: "(one per site)"). A bad number is named without
    an index (`real_values`)."""
    array = real_values(value, name)
    if array.ndim == 0:
        return np.full(n, float(array))
    if array.shape[0] != n:
        per = f" (one per {each})" if each else ""
        raise ValueError(f"{name} must have {n} entries{per}, got {array.shape[0]}")
    return array


def positive_pair(value: Any, name: str, what: str) -> tuple[float, float]:
    """One positive value (used twice) or a pair (first, second) of positive values."""
    array = real_values(value, name)
    if array.ndim == 0:
        array = np.array([float(array), float(array)])
    if array.shape != (2,):
        raise ValueError(f"{name} must be one value or a pair (first, second), got shape {array.shape}")
    positive(array, name, what)
    return float(array[0]), float(array[1])


def increasing(values: NDArray[Any], name: str, what: str) -> None:
    """Raise naming the first entry of 1-D `values` that is not above the one before it."""
    step = np.diff(values)
    if (step <= 0).any():
        i = int(np.argmax(step <= 0)) + 1
        raise ValueError(f"{name}[{i}] is {values[i].item()!r} <= {name}[{i - 1}] = {values[i - 1].item()!r}; "
                         f"{what} must increase")


def increasing_counts(value: Any, name: str) -> NDArray[np.int64]:
    """(n,) strictly increasing integers, n >= 2 (e.g. chain sizes for a fit)."""
    sizes = np.asarray(value)
    if sizes.ndim != 1 or sizes.size < 2 or not np.issubdtype(sizes.dtype, np.integer):
        raise ValueError(f"{name} must be a 1-D sequence of at least two int sizes, got {value!r}")
    increasing(sizes, name, "sizes")
    return sizes.astype(np.int64)


def integration_tolerances(rtol: Any, atol: Any) -> tuple[float, float]:
    """(rtol, atol) for `scipy.integrate.solve_ivp`, each positive and finite."""
    out = []
    for value, name in ((rtol, "rtol"), (atol, "atol")):
        number = real_scalar(value, name)
        if not number > 0:
            raise ValueError(f"{name} is {number!r}; an integration tolerance must be positive")
        out.append(number)
    return out[0], out[1]


def indices(value: Any, name: str, size: int, *, shape: tuple[int, ...] = (-1,), what: str = "site"
            ) -> NDArray[np.intp]:
    """Integer indices in [0, size), reshaped to `shape` (an empty input gives no indices)."""
    array = np.asarray(value)
    if array.size == 0:
        return np.zeros((0,) + shape[1:], dtype=np.intp)
    if not np.issubdtype(array.dtype, np.integer):
        raise TypeError(f"{name} must hold integer {what} indices, got dtype {array.dtype}")
    try:
        array = array.reshape(shape)
    except ValueError:
        raise ValueError(f"{name} must have shape {('n',) + shape[1:]}, got {np.shape(value)}") from None
    bad = (array < 0) | (array >= size)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = ",".join(str(i) for i in index)
        raise ValueError(f"{name}[{where}] is {array[index]}; {what} indices run from 0 to {size - 1}")
    return array.astype(np.intp)
