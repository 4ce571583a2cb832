"""The examples of docs/response.md run as written and say what they compute (issue 16, item 6).

Truth: the receptance x(w) = (K - w^2 M + i w C)^-1 f solved densely with numpy.linalg.solve,
independent of vibra.response.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

DOC = Path(__file__).resolve().parents[2] / "docs" / "response.md"


def multi_dof_block() -> str:
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("## Multi-dof frequency response"):]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)[0]


def exact(namespace: dict[str, Any], omegas: np.ndarray) -> np.ndarray:
    K = np.asarray(namespace["K"].toarray())
    M = np.diag(namespace["M"])
    C = namespace["C"]
    C = np.asarray(C.toarray() if hasattr(C, "toarray") else C)
    C = np.diag(C) if C.ndim == 1 else C
    f = namespace["f"]
    return np.array([np.linalg.solve(K - w * w * M + 1j * w * C, f) for w in omegas])


@pytest.fixture(scope="module")
def example() -> dict[str, Any]:
    namespace: dict[str, Any] = {}
    exec(compile(multi_dof_block(), str(DOC), "exec"), namespace)  # the block asserts its own claims
    return namespace


def relative_error(approx: np.ndarray, truth: np.ndarray) -> np.ndarray:
    return np.linalg.norm(approx - truth, axis=1) / np.linalg.norm(truth, axis=1)


def test_direct_example_matches_a_dense_solve(example: dict[str, Any]) -> None:
    truth = exact(example, example["omegas"])
    assert relative_error(example["x"], truth).max() < 1e-9


def test_modal_example_is_accurate_in_its_band(example: dict[str, Any]) -> None:
    res = example["res"]
    error = relative_error(res.response, exact(example, example["low"]))
    assert error.max() < 0.004  # "below 0.4 %"
    assert np.all(res.truncation_error >= error)  # the estimate bounds the true error below the dropped modes
    assert res.truncation_error.max() < 0.006  # "at most 0.6 %"


def test_the_text_about_twenty_modes_over_the_whole_band_holds(example: dict[str, Any]) -> None:
    from vibra.response import frequency_response

    ns = example
    omegas = ns["omegas"]
    truth = exact(ns, omegas)
    few = frequency_response(ns["K"], ns["M"], ns["C"], omegas, ns["f"], method="modal", n_modes=20,
                             residual_correction=True)
    error = relative_error(few.response, truth)
    assert np.mean(error > 0.01) >= 0.9 and 3.0 < error.max() < 3.6  # "93 %", "up to 330 %"
    assert few.truncation_error.max() > 1e2  # its own estimate flags it
    every = frequency_response(ns["K"], ns["M"], ns["C"], omegas, ns["f"], method="modal", n_modes=200)
    assert relative_error(every.response, truth).max() < 1e-9  # "exact to 1e-11" (1e-9 with margin)
