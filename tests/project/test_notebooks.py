"""The teaching notebooks in notebooks/ run top to bottom in a fresh kernel.

Each notebook asserts its own key numbers (closed forms, experiment, ASE/phonopy), so
executing it is the test: any exception, a failed ``assert`` included, fails here. The
committed files must carry no outputs and no execution counts.
"""

from __future__ import annotations

import ast
import os
import re
from pathlib import Path

import nbformat
import numpy as np
import pytest
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

NOTEBOOK_DIR = Path(__file__).resolve().parents[2] / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
#: Notebooks that compute with a package outside the base install on some platforms: PySCF is a
#: base dependency except on Windows, where it has no wheels (pyproject.toml).
NEEDS = {"ir_raman": "pyscf"}
_ANSI = re.compile(r"\x1b\[[0-9;]*m")  # colour codes in kernel tracebacks


def test_notebooks_are_present() -> None:
    """The glob below must not silently parametrize over nothing."""
    assert len(NOTEBOOKS) >= 1, f"no notebooks found in {NOTEBOOK_DIR}"


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_executes(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Run every cell in a fresh python3 kernel whose working directory is a temporary one."""
    if path.stem in NEEDS:
        pytest.importorskip(NEEDS[path.stem])
    # The kernel inherits this environment: off-screen matplotlib and pyvista, one BLAS thread and
    # one OpenMP thread (PySCF's integrals; CI has 2 cores, and on a busy machine OpenMP threads
    # waiting at their barriers made ir_raman 2.6x slower, 110 s against 42 s).
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("PYVISTA_OFF_SCREEN", "true")
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    # The kernel must import this checkout's vibra even when it is not installed.
    repo = str(NOTEBOOK_DIR.parent)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [repo, os.environ.get("PYTHONPATH")])))
    notebook = nbformat.read(path, as_version=4)
    before = sorted(NOTEBOOK_DIR.iterdir())
    client = NotebookClient(notebook, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}})
    try:
        client.execute()
    except CellExecutionError as error:  # fail, never skip, with the cell's traceback
        pytest.fail(f"{path.name} failed:\n{_ANSI.sub('', str(error))}")
    # A notebook writes only into temporary directories, never beside itself.
    assert sorted(NOTEBOOK_DIR.iterdir()) == before, f"{path.name} wrote into {NOTEBOOK_DIR}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_committed_clean(path: Path) -> None:
    """Outputs stripped, no execution counts, the standard python3 kernel."""
    notebook = nbformat.read(path, as_version=4)
    nbformat.validate(notebook)
    assert notebook.metadata.get("kernelspec", {}).get("name") == "python3"
    for index, cell in enumerate(notebook.cells):
        if cell.cell_type != "code":
            continue
        assert cell.get("outputs") == [], f"{path.name} cell {index} has outputs"
        assert cell.get("execution_count") is None, f"{path.name} cell {index} has an execution count"


def _asserts(source: str) -> list[ast.Assert]:
    """The ``assert`` statements of notebook code (IPython magics and shell lines dropped)."""
    lines = [line for line in source.splitlines() if not line.lstrip().startswith(("%", "!"))]
    return [node for node in ast.walk(ast.parse("\n".join(lines))) if isinstance(node, ast.Assert)]


def _checks_a_computed_value(node: ast.Assert) -> bool:
    """An assertion that can fail: its test is no literal and reads at least one variable."""
    if isinstance(node.test, ast.Constant):
        return False
    return any(isinstance(child, ast.Name) for child in ast.walk(node.test))


def test_assertion_counter_sees_only_real_assertions() -> None:
    """The counter below ignores the word in comments and strings and constant assertions."""
    constant = "assert " + "True"  # a literal assertion, which can never fail
    source = ('# assert x == 1\ntext = "assert y"\n' + constant + '\n%matplotlib inline\n'
              'assert abs(omega - 1.0) < 1e-12\n')
    assert [_checks_a_computed_value(node) for node in _asserts(source)] == [False, True]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_asserts_its_numbers(path: Path) -> None:
    """Each notebook checks at least 3 of its key numbers with real ``assert`` statements.

    Counted on the parsed code (not the text), so a comment, a string or a constant
    assertion does not count; `test_notebook_executes` runs them, so each one can fail.
    """
    notebook = nbformat.read(path, as_version=4)
    code = "\n".join(cell.source for cell in notebook.cells if cell.cell_type == "code")
    real = [node for node in _asserts(code) if _checks_a_computed_value(node)]
    assert len(real) >= 3, f"{path.name} asserts {len(real)} computed numbers; at least 3 expected"


# ---------------------------------------------------------------------- vibra.charts.notebooks
# The chart functions written for the notebooks: figures drawn, inputs validated.

def test_plot_cost_vs_error_draws_one_point_per_run() -> None:
    from vibra.charts.notebooks import plot_cost_vs_error

    fig = plot_cost_vs_error(["dense", "accurate"], [0.1, 0.2], [1e-10, 1e-15], groups=["N=10", "N=10"])
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert sum(len(line.get_xdata()) for line in ax.get_lines()) == 2
    assert "s" in ax.get_xlabel()  # wall time carries its unit


@pytest.mark.parametrize(("args", "error", "match"), [
    ((["a"], [1.0], [0.0]), ValueError, r"errors\[0\] is 0.0"),
    ((["a"], [-1.0], [1.0]), ValueError, r"seconds\[0\] is -1.0"),
    ((["a", "b"], [1.0], [1.0]), ValueError, r"labels has 2 entries; expected 1"),
    ((["a"], [1.0, 2.0], [1.0, 2.0]), ValueError, r"labels has 1 entries; expected 2"),
    ((["a", "b"], [1.0, 2.0], [1.0]), ValueError, r"errors has 1 values; expected 2"),
    (("ab", [1.0, 2.0], [1.0, 2.0]), TypeError, r"labels must be a sequence of str"),
    (([1, 2], [1.0, 2.0], [1.0, 2.0]), TypeError, r"labels\[0\] must be a str"),
    ((["a", "b"], [1.0, 2.0], [1.0, 2.0], ["g"]), ValueError, r"groups has 1 entries; expected 2"),
    ((["a"], [1.0], [1.0], [3]), TypeError, r"groups\[0\] must be a str"),
])
def test_plot_cost_vs_error_validates(args: tuple, error: type, match: str) -> None:
    from vibra.charts.notebooks import plot_cost_vs_error

    labels, seconds, errors, *groups = args
    with pytest.raises(error, match=match):
        plot_cost_vs_error(labels, seconds, errors, groups=groups[0] if groups else None)


def test_plot_step_errors_guides_follow_the_order() -> None:
    from vibra.charts.notebooks import plot_step_errors

    steps = np.array([1e-3, 1e-2, 1e-1])
    errors = np.vstack([steps**2, steps**4])
    fig = plot_step_errors(steps, errors, ["2-point", "4-point"], estimates=errors, orders=[2, 4])
    guides = [line for line in fig.axes[0].get_lines() if line.get_linestyle() == ":"]
    assert len(guides) == 2
    for guide, p in zip(guides, (2, 4)):
        x, y = guide.get_xdata(), guide.get_ydata()
        slope = np.diff(np.log(y)) / np.diff(np.log(x))
        assert np.allclose(slope, p, rtol=1e-12)  # a power law h^p drawn exactly


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"errors": [[1.0, 2.0]]}, ValueError, r"errors has 2 columns; expected 3"),
    ({"estimates": [[1.0, 2.0, -1.0]]}, ValueError, r"estimates\[0,2\] is -1.0"),
    ({"estimates": [[1.0, 2.0]]}, ValueError, r"estimates has shape \(1, 2\); expected \(1, 3\)"),
    ({"orders": [2.0, 4.0]}, ValueError, r"orders has 2 values; expected 1"),
    ({"labels": ["a", "b"]}, ValueError, r"labels has 2 entries; expected 1"),
    ({"steps": [0.0, 1.0, 2.0]}, ValueError, r"steps\[0\] is 0.0"),
])
def test_plot_step_errors_validates(kwargs: dict, error: type, match: str) -> None:
    from vibra.charts.notebooks import plot_step_errors

    arguments = {"steps": [1.0, 2.0, 3.0], "errors": [[1.0, 2.0, 3.0]], "labels": ["a"]}
    arguments.update(kwargs)
    with pytest.raises(error, match=match):
        plot_step_errors(**arguments)


def test_plot_time_series_draws_each_signal() -> None:
    from vibra.charts.notebooks import plot_time_series

    t = np.linspace(0.0, 1.0, 11)
    fig = plot_time_series(t, [np.sin(t), np.cos(t)], ["sin", "cos"], styles=["-", "k:"],
                           time_label="time t (s)", value_label="u (m)")
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert len(lines) == 2 and np.allclose(lines[1].get_ydata(), np.cos(t))
    assert ax.get_xlabel() == "time t (s)" and ax.get_ylabel() == "u (m)"  # the caller's units


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"series": [[1.0, 2.0]]}, ValueError, r"series has 2 columns; expected 3"),
    ({"series": [1.0, 2.0, 3.0]}, ValueError, r"series"),
    ({"labels": ["a", "b"]}, ValueError, r"labels has 2 entries; expected 1"),
    ({"styles": ["-", "--"]}, ValueError, r"styles has 2 entries; expected 1"),
    ({"styles": "-"}, TypeError, r"styles must be a sequence of str"),
    ({"time_label": None}, TypeError, r"time_label must be a str \(an axis label with its unit\), got NoneType"),
    ({"value_label": 1.0}, TypeError, r"value_label must be a str"),
    ({"t": [0.0, np.nan, 2.0]}, ValueError, r"t\[1\]"),
])
def test_plot_time_series_validates(kwargs: dict, error: type, match: str) -> None:
    from vibra.charts.notebooks import plot_time_series

    arguments = {"t": [0.0, 1.0, 2.0], "series": [[1.0, 2.0, 3.0]], "labels": ["a"],
                 "time_label": "t (s)", "value_label": "u (m)"}
    arguments.update(kwargs)
    with pytest.raises(error, match=match):
        plot_time_series(**arguments)
