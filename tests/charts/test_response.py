"""vibra/charts/response.py keeps its promises (issue 48, item 4): `plot_frf` marks the natural
frequencies for every response method, and the charts name the unit system's units.

Truth: the closed form of a fixed-fixed chain of N unit masses and unit springs,
omega_k = 2 sin(k pi / (2 (N + 1))), k = 1..N, computed here, not by vibra.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from vibra.charts.response import plot_frf, plot_rayleigh_damping
from vibra.response import frequency_response, friction_damping

N = 12
CLOSED_FORM = 2.0 * np.sin(np.arange(1, N + 1) * np.pi / (2 * (N + 1)))
BAND = np.linspace(0.3, 1.5, 200)  # holds some of the chain's modes, not all


def chain() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    K = 2.0 * np.eye(N) - np.eye(N, k=1) - np.eye(N, k=-1)
    M = np.ones(N)
    f = np.zeros(N)
    f[0] = 1.0
    return K, M, f


def marked(figure) -> list[np.ndarray]:
    """Per panel, the sorted x of the vertical lines drawn across it (axvline: x = (f, f), y = (0, 1))."""
    out = []
    for axis in figure.axes:
        xs = [float(line.get_xdata()[0]) for line in axis.get_lines()
              if len(line.get_xdata()) == 2 and line.get_xdata()[0] == line.get_xdata()[1]
              and list(line.get_ydata()) == [0, 1]]
        out.append(np.sort(xs))
    return out


EXPECTED = CLOSED_FORM[(CLOSED_FORM >= BAND[0]) & (CLOSED_FORM <= BAND[-1])]


@pytest.mark.parametrize("method", ["direct", "modal"])
def test_every_natural_frequency_in_the_band_is_marked(method: str) -> None:
    K, M, f = chain()
    result = frequency_response(K, M, friction_damping(M, 0.05), BAND, f, method=method)
    assert 3 <= EXPECTED.size < N
    # the modal result carries its modes; the direct one takes them from K and M
    figure = plot_frf(result, 0, K=K, M=M) if method == "direct" else plot_frf(result, 0)
    for xs in marked(figure):  # magnitude and phase panels alike
        np.testing.assert_allclose(xs, EXPECTED, rtol=1e-12)
    assert "natural frequencies" in figure.axes[0].get_legend_handles_labels()[1]


def test_the_state_space_result_marks_its_complex_modes() -> None:
    K, M, f = chain()
    result = frequency_response(K, M, friction_damping(M, 1e-6), BAND, f, method="state_space")
    for xs in marked(plot_frf(result, 0)):  # |Im s| = sqrt(w^2 - eta^2/4): the closed form to 1e-12
        np.testing.assert_allclose(xs, EXPECTED, rtol=1e-10)


def test_given_frequencies_win_and_an_empty_list_marks_none() -> None:
    K, M, f = chain()
    result = frequency_response(K, M, friction_damping(M, 0.05), BAND, f, method="modal")
    top, bottom = marked(plot_frf(result, 0, natural_frequencies=[0.5, 9.0], K=K, M=M))
    assert top.tolist() == [0.5] and bottom.tolist() == [0.5]  # 9.0 lies outside the band
    assert all(xs.size == 0 for xs in marked(plot_frf(result, 0, natural_frequencies=())))


def test_a_direct_result_without_frequencies_is_refused_naming_the_fix() -> None:
    K, M, f = chain()
    result = frequency_response(K, M, friction_damping(M, 0.05), BAND, f)
    with pytest.raises(ValueError, match=r"method='direct'\) carries no natural frequencies; give K and M"):
        plot_frf(result, 0)
    with pytest.raises(ValueError, match="give K and M together"):
        plot_frf(result, 0, K=K)
    with pytest.raises(ValueError, match=r"K has shape \(2, 2\); expected \(12, 12\)"):
        plot_frf(result, 0, K=np.eye(2), M=np.ones(2))
    gyroscopic = frequency_response(np.eye(2), [1.0, 1.0], None, [0.2, 0.4], [1.0, 0.0],
                                    G=np.array([[0.0, -1.0], [1.0, 0.0]]))
    with pytest.raises(ValueError, match="a gyroscopic result's resonances"):
        plot_frf(gyroscopic, 0, K=np.eye(2), M=[1.0, 1.0])


def test_si_matrices_get_si_axes_and_bare_matrices_say_time_unit() -> None:
    K, M, f = chain()
    si = frequency_response(1e3 * K, 2.0 * M, None, 40.0 * BAND, f, units="SI")  # N/m, kg
    figure = plot_frf(si, 0, K=1e3 * K, M=2.0 * M)
    assert figure.axes[1].get_xlabel().endswith("(rad/s)")
    assert figure.axes[0].get_ylabel().endswith("per unit force (m/N)")
    np.testing.assert_allclose(marked(figure)[0], np.sqrt(500.0) * CLOSED_FORM[
        (np.sqrt(500.0) * CLOSED_FORM >= 40.0 * BAND[0]) & (np.sqrt(500.0) * CLOSED_FORM <= 40.0 * BAND[-1])],
        rtol=1e-12)
    bare = frequency_response(K, M, None, BAND + 0.01, f)
    assert plot_frf(bare, 0, K=K, M=M).axes[1].get_xlabel().endswith("(rad / time unit)")
    assert plot_rayleigh_damping(0.1, 0.01, BAND, units="SI").axes[0].get_xlabel().endswith("(rad/s)")
    assert plot_rayleigh_damping(0.1, 0.01, BAND).axes[0].get_xlabel().endswith("(rad / time unit)")


def test_the_units_example_of_the_docs_runs_and_labels_si_axes(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "response.md").read_text(encoding="utf-8")
    block = re.findall(r"```python\n(.*?)```", text[text.index("## Units"):], re.S)[0]
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(block, "docs/response.md, Units", "exec"), namespace)  # it asserts the SI labels itself
    k, m = 1e4, 1.0
    np.testing.assert_allclose(marked(namespace["figure"])[0], [np.sqrt(k / m), np.sqrt(3 * k / m)], rtol=1e-12)
    assert (tmp_path / "two_masses_frf.png").stat().st_size > 0
