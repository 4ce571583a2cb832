"""One result protocol for every result type (issue 43, item 4): a short one-line repr,
`to_dict` / `from_dict`, `save` / `load` to one versioned ``.npz`` checked whole before use,
``len`` and slicing along the natural axis, and `path` for how it was computed.

Each result is built small and real through the public API. Truth: the result itself (what
comes back from a dict or a file equals it entry by entry, dtype included), what a slice must
hold (the arrays along the axis, nothing else changed), and hand-made files that a result
file must refuse in one line naming the file and the entry.
"""

from __future__ import annotations

import dataclasses
import io
import math
import zipfile
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

import vibra
from vibra import crystals, dynamics, spectra
from vibra import molecules as mol
from vibra._results import Result, axis_arrays, layout
from vibra.chains import linear_chain
from vibra.pipeline.sweep import sweep
from vibra.response import frequency_response, transient_response


def _argon() -> Any:
    return crystals.fcc(5.26, 39.948, 0.0325, units="ASE")


def _water() -> tuple[Any, Any]:
    system = mol.h2o()
    return system, mol.vibrational_analysis(system)


def _ir() -> Any:
    system, analysis = _water()
    return spectra.ir_spectrum(system, analysis, charges=[-0.8 if s == "O" else 0.4 for s in system.symbols])


def _damped() -> Any:
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    return vibra.System.generalized(np.eye(2), K, C=0.1 * np.eye(2) + [[0.0, 0.05], [0.05, 0.0]]).quadratic_modes()


def _trajectory() -> Any:
    system = vibra.chains.linear_chain(4, units="dimensionless")
    return dynamics.integrate(system, [0.1, 0.0, -0.1, 0.05], [0.0, 0.2, 0.0, 0.0], 0.05, 20,
                              thermostat=dynamics.NoseHoover(1.0, 1.0, chain=2))


K3 = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 2.0]])

#: Every public result type, built small: name -> maker.
MAKERS: dict[str, Callable[[], Any]] = {
    "Modes": lambda: linear_chain(6).modes(),
    "Modes-frequencies-only": lambda: linear_chain(6).modes(vectors=False),
    "QuadraticModes": _damped,
    "Phonons": lambda: _argon().phonons([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.1, 0.0], [0.5, 0.5, 0.0]],
                                        vectors=True),
    "BandStructure": lambda: _argon().band_structure(npoints=40),
    "DensityOfStates": lambda: _argon().dos(4, projected=True),
    "ThermalProperties": lambda: _argon().thermal_properties([10.0, 100.0, 300.0], mesh=4),
    "Trajectory": _trajectory,
    "FrequencyResponse": lambda: frequency_response(K3, np.ones(3), 0.1 * np.eye(3), np.linspace(0.1, 3.0, 5),
                                                    [1.0, 0.0, 0.0]),
    "FrequencyResponse-modal": lambda: frequency_response(K3, np.ones(3), None, np.linspace(0.1, 3.0, 5),
                                                          [1.0, 0.5j, 0.0], method="modal", damping_ratios=0.05),
    "Transient": lambda: transient_response(K3, np.ones(3), 0.1 * np.eye(3), np.linspace(0.0, 2.0, 9),
                                            [1.0, 0.0, 0.0], omega=1.0),
    "SweepTable": lambda: sweep(linear_chain, {"n": [3, 4, 5]}),
    "IRSpectrum": _ir,
    "RamanSpectrum": lambda: spectra.raman_spectrum(*_water(), bonds=[[0, 1], [0, 2]]),
    "StickSpectrum": lambda: _ir().sticks(),
    "BroadenedSpectrum": lambda: _ir().sticks().broadened(np.linspace(1000.0, 4000.0, 31), 20.0),
    "Thermochemistry": lambda: spectra.thermochemistry(_water()[1], [100.0, 300.0, 500.0]),
    "IdealGasThermochemistry": lambda: spectra.ideal_gas_thermochemistry(_water()[1], [100.0, 300.0, 500.0], 1e5,
                                                                         symmetry_number=2, geometry=mol.h2o()),
    "IsotopeShifts": lambda: spectra.isotope_shifts(mol.h2o(), {1: "D"}),
}

_BUILT: dict[str, Any] = {}


@pytest.fixture(params=sorted(MAKERS))
def result(request: pytest.FixtureRequest) -> Any:
    if request.param not in _BUILT:  # each built once: results are frozen
        _BUILT[request.param] = MAKERS[request.param]()
    assert type(_BUILT[request.param]).__name__ == request.param.partition("-")[0]
    return _BUILT[request.param]


def same(a: Result, b: Result) -> None:
    """`a` and `b` store the same: every entry of `to_dict` equal, arrays with their dtype."""
    assert type(a) is type(b)
    x, y = a.to_dict(), b.to_dict()
    assert x.keys() == y.keys()
    for key in x:
        if isinstance(x[key], np.ndarray):
            np.testing.assert_array_equal(x[key], y[key], err_msg=key)
            assert x[key].dtype == y[key].dtype, key
        else:
            assert x[key] == y[key] or (isinstance(x[key], float) and math.isnan(x[key]) and math.isnan(y[key])), key


def test_every_result_type_is_covered() -> None:
    # ThermoContribution is covered inside IdealGasThermochemistry (its parts, stored and sliced with it)
    named = {name.partition("-")[0] for name in MAKERS}
    assert {cls.__name__ for cls in _subclasses(Result)} - {"ModesResult", "ThermoContribution"} == named


def _subclasses(cls: type) -> set[type]:
    return {sub for direct in cls.__subclasses__() for sub in {direct, *_subclasses(direct)}}


def test_repr_is_one_short_line_with_the_sizes_the_path_and_no_array(result: Result) -> None:
    text = repr(result)
    assert "\n" not in text and len(text) < 200 and "array(" not in text, text
    assert text.startswith(f"{type(result).__name__}({len(result)} "), text
    assert f"path {result.path!r}" in text, text


def test_path_is_a_short_name(result: Result) -> None:
    assert isinstance(result.path, str) and result.path and "\n" not in result.path


def test_every_array_field_is_declared_and_frozen(result: Result) -> None:
    stored = layout(type(result)).arrays
    for field in dataclasses.fields(result):  # type: ignore[arg-type]
        value = getattr(result, field.name)
        if isinstance(value, np.ndarray):
            assert field.name in stored, field.name
            assert not value.flags.writeable, field.name
    name = dataclasses.fields(result)[0].name  # type: ignore[arg-type]
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(result, name, None)


def test_dict_round_trip_is_exact(result: Result) -> None:
    data = result.to_dict()
    assert data["format"] == 1 and data["type"] == type(result).__name__
    same(type(result).from_dict(data), result)


def test_save_load_round_trip_is_exact(result: Result, tmp_path: Path) -> None:
    path = result.save(tmp_path / "result.npz")
    loaded = type(result).load(path)
    same(loaded, result)
    assert repr(loaded) == repr(result) and loaded.path == result.path and len(loaded) == len(result)
    assert all(not value.flags.writeable for value in vars(loaded).values() if isinstance(value, np.ndarray))
    assert [p.name for p in tmp_path.iterdir()] == ["result.npz"]


def test_len_and_slices_give_a_smaller_result_of_the_same_type(result: Result, tmp_path: Path) -> None:
    count = len(result)
    assert count >= 2
    for index, size in ((slice(1, None), count - 1), (0, 1), (-1, 1), (slice(0, 2), 2), (slice(0, 0), 0)):
        part = result[index]
        assert type(part) is type(result) and len(part) == size
        assert part.path == result.path or type(result).__name__ == "SweepTable"  # (its rows' paths)
        whole, cut = result.to_dict(), part.to_dict()
        for key, value in whole.items():  # the axis's arrays shrink; nothing else changes
            if isinstance(value, np.ndarray) and key in _axis_arrays(result):
                axis, width = _axis_arrays(result)[key]
                picked = np.arange(count)[index]
                columns = (np.atleast_1d(picked)[:, None] * width + np.arange(width)).ravel()
                np.testing.assert_array_equal(cut[key], np.take(value, columns, axis=axis), err_msg=key)
            elif isinstance(value, np.ndarray) and type(result).__name__ not in ("SweepTable", "BandStructure"):
                np.testing.assert_array_equal(cut[key], value, err_msg=key)
        same(type(result).from_dict(cut), part)  # a slice is consistent: its dict passes the checks
        same(type(result).load(part.save(tmp_path / "part.npz")), part)
    with pytest.raises(IndexError, match="out of range"):
        result[count]


def _axis_arrays(result: Result) -> dict[str, tuple[int, int]]:
    out = {key: spec for key, spec in axis_arrays(type(result)).items() if getattr(result, key) is not None}
    for name, part in type(result).NESTED.items():  # a part's arrays, sliced with it
        out.update({f"{name}.{key}": spec for key, spec in axis_arrays(part).items()})
    return out


def test_a_band_structure_slice_keeps_its_segments_labels_and_breaks_consistent() -> None:
    bands = _argon().band_structure(npoints=60)
    first, last = bands.segments[1]
    part = bands[first - 2:last + 3]  # the end of segment 0, all of segment 1, the start of segment 2
    np.testing.assert_array_equal(part.segments, [[0, 1], [2, 2 + last - first], [3 + last - first, len(part) - 1]])
    assert part.labels == tuple((k - (first - 2), label) for k, label in bands.labels if first - 2 <= k <= last + 2)
    assert all(0 < k < len(part) for k in part.breaks)
    np.testing.assert_array_equal(part.distances, bands.distances[first - 2:last + 3])
    with pytest.raises(IndexError, match="contiguous"):
        bands[::2]
    with pytest.raises(ValueError, match=r"data\['labels'\] holds an index outside the 60 q-points"):
        type(bands).from_dict({**bands.to_dict(), "labels": [[60, "X"]]})


def test_a_sweep_table_stores_its_rows_as_columns(tmp_path: Path) -> None:
    table = sweep(linear_chain, {"n": [3, 4, 5]})
    data = table.to_dict()
    assert data["n_omega"].tolist() == [3, 4, 5] and data["omega"].shape == (12,)
    loaded = type(table).load(table.save(tmp_path / "t.npz"))
    assert loaded.json_text() == table.json_text() and loaded.csv_text() == table.csv_text()
    assert [row.index for row in table[1:].rows] == [1, 2]
    with pytest.raises(ValueError, match=r"data\['n_omega'\] sums to 11"):
        type(table).from_dict({**data, "n_omega": np.array([3, 4, 4])})
    assert table.rows[0].as_json() == table.rows[0].to_dict()


def test_a_sweep_table_keeps_its_rows_in_arrays_not_in_json(tmp_path: Path) -> None:
    # the JSON entry is capped at 1 MiB: a table of 10^5 rows must keep its rows' names and numbers in arrays
    from vibra.pipeline.sweep import SweepRow, SweepTable

    rng = np.random.default_rng(7)
    rows = tuple(SweepRow(index=k, parameters=(("member", k), ("system.k", float(rng.uniform(1, 2)))),
                          omega=np.sort(rng.uniform(0, 3, 1 + k % 3)), derived=(("gap", float(rng.normal())),),
                          solver=("dense", "tridiagonal")[k % 2], residual=float("nan"), omega_error=1e-15,
                          units="SI", branch=np.arange(1 + k % 3)) for k in range(2_000))
    table = SweepTable(name="big", keys=("member",), units="SI", rows=rows)
    path = table.save(tmp_path / "big.npz")
    with zipfile.ZipFile(path) as archive:
        assert archive.getinfo("__scalars__.npy").file_size < 1024  # the same for any number of rows
    loaded = SweepTable.load(path)
    same(loaded, table)
    assert loaded.path == "dense+tridiagonal" and loaded.rows[5].omega.tolist() == rows[5].omega.tolist()
    assert [type(value) for _, value in loaded.rows[3].parameters] == [int, float]


def test_old_names_of_the_path_keep_working() -> None:
    modes, quadratic = linear_chain(4).modes(), _damped()
    response = MAKERS["FrequencyResponse"]()
    assert modes.path == modes.solver and quadratic.path == quadratic.method
    assert response.path == response.method == "direct" and response.solver  # the linear solver, kept apart
    assert _argon().dos(4).path == _argon().dos(4).method == "tetrahedron"
    trajectory = _trajectory()
    assert trajectory.path == trajectory.integrator == "verlet"


# ---------------------------------------------------------------------- files that must be refused
def _npy(array: np.ndarray | None = None, *, shape: tuple[int, ...] = (), descr: str = "<f8") -> bytes:
    buffer = io.BytesIO()
    if array is not None:
        np.lib.format.write_array(buffer, array, allow_pickle=False)
    else:  # a header alone: it declares `shape` and holds nothing
        np.lib.format.write_array_header_1_0(buffer, {"descr": descr, "fortran_order": False, "shape": shape})
    return buffer.getvalue()


def _rewrite(source: Path, target: Path, key: str, entry: bytes) -> Path:
    with zipfile.ZipFile(source) as archive, zipfile.ZipFile(target, "w") as out:
        for info in archive.infolist():
            out.writestr(info.filename, entry if info.filename == f"{key}.npy" else archive.read(info))
    return target


def _second_of_a_size(result: Result) -> tuple[str, tuple[int, ...]]:
    """An array entry that shares a named size with an earlier one, and a shape one larger there."""
    spec, data, seen = layout(type(result)), result.to_dict(), set()
    found = None
    for key, stored in spec.arrays.items():
        if not isinstance(data.get(key), np.ndarray):
            continue
        pattern = next(p for p in stored.shapes if len(p) == data[key].ndim)
        names = [d if isinstance(d, str) else d[0] if isinstance(d, tuple) else None for d in pattern]
        shared = [i for i, name in enumerate(names) if name is not None and name in seen]
        if shared:
            shape = list(data[key].shape)
            factor = pattern[shared[0]][1] if isinstance(pattern[shared[0]], tuple) else 1
            shape[shared[0]] += factor
            found = (key, tuple(shape))
        seen.update(name for name in names if name is not None)
    assert found is not None
    return found


def test_a_field_of_the_wrong_shape_is_refused_in_one_line(result: Result, tmp_path: Path) -> None:
    key, shape = _second_of_a_size(result)
    data = result.to_dict()
    wrong = np.zeros(shape, dtype=data[key].dtype)
    path = _rewrite(result.save(tmp_path / "good.npz"), tmp_path / "bad.npz", key, _npy(wrong))
    with pytest.raises(ValueError) as refused:
        type(result).load(path)
    message = str(refused.value)
    assert message.startswith(f"{path}: {key} has shape {shape}; expected") and "\n" not in message, message
    with pytest.raises(ValueError, match=rf"data\['{key}'\] has shape"):
        type(result).from_dict({**data, key: wrong})


def test_a_declared_huge_shape_is_refused_before_it_is_read(result: Result, tmp_path: Path) -> None:
    key = next(key for key, value in result.to_dict().items() if isinstance(value, np.ndarray))
    path = _rewrite(result.save(tmp_path / "good.npz"), tmp_path / "bad.npz", key, _npy(shape=(10**9, 10**3)))
    with pytest.raises(ValueError) as refused:
        type(result).load(path)
    message = str(refused.value)
    assert message.startswith(f"{path}: {key} declares (1000000000, 1000)") and "\n" not in message, message


def test_another_type_is_refused(result: Result, tmp_path: Path) -> None:
    path = result.save(tmp_path / "r.npz")
    other = vibra.Modes if type(result) is not vibra.Modes else spectra.StickSpectrum
    with pytest.raises(ValueError, match=rf"{path}: type is '{type(result).__name__}'; expected '{other.__name__}'"):
        other.load(path)


# ---------------------------------------------------------------------- System
def test_the_repr_of_a_256_site_crystal_supercell_is_one_short_line() -> None:
    basis = np.array([[0.0, 0.0, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5], [0.5, 0.5, 0.0]])
    positions = np.array([corner + b for corner in np.ndindex(4, 4, 4) for b in basis])
    gap = positions[:, None, :] - positions[None, :, :]
    gap -= 4.0 * np.round(gap / 4.0)  # minimum image in the 4 x 4 x 4 box of cubes
    near = np.isclose(np.linalg.norm(gap, axis=-1), np.sqrt(0.5))
    pairs = np.argwhere(np.triu(near))
    system = vibra.System.from_springs(positions, 1.0, pairs, 1.0, cell=4.0 * np.eye(3), frozen_sites=[0],
                                       name="fcc-256")
    assert len(system.labels) == 768 and len(pairs) == 256 * 6
    text = repr(system)
    assert text == "System('fcc-256', 256 sites in 3-D, 765 dofs, 3 dofs frozen, SI units)"


# ---------------------------------------------------------------------- VibrationalAnalysis
def test_the_repr_of_a_vibrational_analysis_is_one_line_without_arrays() -> None:
    """Not a stored result (it holds its system), but printed as often: one line, no array."""
    analysis = mol.vibrational_analysis(mol.molecule("CO2"))
    text = repr(analysis)
    assert "\n" not in text and "array" not in text and len(text) < 120
    assert text.startswith("VibrationalAnalysis(CO2: 4 vibrations, 5 rigid-body modes, linear, path ")
