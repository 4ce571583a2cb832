"""Input checks shared by the public functions.

Each check takes the argument's public ``name`` and raises an error that names it, states
the requirement and shows what arrived (STYLE.md, "Validation names the offending input").
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

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


def real_array(value: Any, name: str, *, ndim: int | tuple[int, ...] | None = None) -> NDArray[np.float64]:
    """`value` as a finite float64 ndarray; raise naming `name` otherwise."""
    if sp.issparse(value):
        raise TypeError(f"{name} must be a dense array here, got a scipy.sparse matrix")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"{name} must be an array of real numbers, got {type(value).__name__}"
        ) from None
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else ndim
        if array.ndim not in allowed:
            want = " or ".join(f"{d}-D" for d in allowed)
            raise ValueError(f"{name} must be {want}, got shape {array.shape}")
    finite(array, name)
    return array


def finite(array: NDArray[Any], name: str) -> None:
    """Raise if `array` holds NaN or inf, giving the first offending index."""
    bad = ~np.isfinite(array)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = ",".join(str(i) for i in index)
        raise ValueError(f"{name}[{where}] is {_scalar(array[index])}; every entry must be finite")


def positive(array: NDArray[np.float64], name: str, what: str = "value") -> None:
    """Raise if any entry of `array` is not strictly positive (and finite)."""
    finite(array, name)
    bad = ~(array > 0)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = ",".join(str(i) for i in index)
        raise ValueError(f"{name}[{where}] is {_scalar(array[index])}; every {what} must be positive and finite")


def nonnegative(array: NDArray[np.float64], name: str, what: str = "value") -> None:
    """Raise if any entry of `array` is negative or not finite."""
    finite(array, name)
    bad = array < 0
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = ",".join(str(i) for i in index)
        raise ValueError(f"{name}[{where}] is {_scalar(array[index])}; every {what} must be >= 0")


def square_matrix(value: Any, name: str) -> NDArray[np.float64] | sp.csr_matrix:
    """`value` as a finite square float matrix, dense ndarray or CSR."""
    if sp.issparse(value):
        matrix = sp.csr_matrix(value, dtype=float)
        finite(matrix.data, f"{name}.data")
    else:
        matrix = real_array(value, name, ndim=2)
    if matrix.shape[0] != matrix.shape[1]:
        raise ValueError(f"{name} must be square, got shape {matrix.shape}")
    if matrix.shape[0] == 0:
        raise ValueError(f"{name} must have at least one row, got shape {matrix.shape}")
    return matrix


def symmetric(
    matrix: NDArray[np.float64] | sp.csr_matrix, name: str, *, symmetrize: bool = False,
    rtol: float = SYMMETRY_RTOL,
) -> NDArray[np.float64] | sp.csr_matrix:
    """Check symmetry within ``rtol * max|matrix|``; with `symmetrize`, return (A + A^T) / 2."""
    if isinstance(matrix, sp.spmatrix) or sp.issparse(matrix):
        sparse_matrix: Any = matrix
        gap_matrix = (sparse_matrix - sparse_matrix.T).tocoo()
        scale = abs(sparse_matrix).max() if sparse_matrix.nnz else 0.0
        if gap_matrix.nnz:
            k = int(np.argmax(np.abs(gap_matrix.data)))
            gap, i, j = abs(gap_matrix.data[k]), int(gap_matrix.row[k]), int(gap_matrix.col[k])
        else:
            gap, i, j = 0.0, 0, 0
    else:
        difference = np.abs(matrix - matrix.T)
        i, j = (int(x) for x in np.unravel_index(np.argmax(difference), difference.shape))
        gap = float(difference[i, j])
        scale = float(np.abs(matrix).max())
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


def mass_argument(value: Any, n_dof: int, name: str = "M") -> NDArray[np.float64]:
    """Masses as an (n_dof,) positive vector or an (n_dof, n_dof) SPD matrix."""
    if sp.issparse(value):
        matrix = sp.csr_matrix(value)
        diagonal = matrix.diagonal()
        off_diagonal = matrix.nnz - np.count_nonzero(diagonal)
        # A diagonal sparse M stays a vector (never densify n x n); a general one is dense.
        value = diagonal if off_diagonal == 0 and matrix.shape[0] == matrix.shape[1] else matrix.toarray()
    masses = real_array(value, name, ndim=(1, 2))
    if masses.ndim == 1:
        if masses.shape[0] != n_dof:
            raise ValueError(f"{name} must have {n_dof} masses to match K, got shape {masses.shape}")
        positive(masses, name, "mass")
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
