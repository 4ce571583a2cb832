"""docs/dynamics.md runs as written: each python block alone, in a fresh namespace, in a scratch folder.

Each block asserts its own claims (the constant kinetic energy and the seed's mu; the KS verdicts;
the recurrence); the checks below hold the page's other figures to the code.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[2] / "docs" / "dynamics.md"
BLOCKS = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)


def test_the_page_has_its_examples() -> None:
    assert len(BLOCKS) == 4


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_each_block_runs_alone(index: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    exec(compile(BLOCKS[index], f"docs/dynamics.md block {index}", "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.strip()          # every block shows what it computes


def test_the_schemes_table_matches_the_code() -> None:
    from vibra import dynamics

    text = DOC.read_text(encoding="utf-8")
    for name, order, limit in (("verlet", 2, "2"), ("yoshida4", 4, "1.573"), ("blanes-moan", 4, "3.163")):
        assert f"{dynamics.STABLE_OMEGA_DT[name]:.4g}" == limit
        assert re.search(rf'`"{name}"`.*\| {order} \|.*\| {re.escape(limit)} \|', text)
    assert "verlet is stable for dt < 2 / omega_max" in text
