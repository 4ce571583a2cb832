"""Counted nouns agree with their number (issue 48, item 6): "1 atom per cell", not "1 atoms".

Truth: English grammar, on the messages the issue names (the crystal cost line, the CLI's and
the report's summaries, `Modes.summary`), and the one helper they all go through.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vibra
from vibra._core.text import counted, plural
from vibra.molecules import h2o

ROOT = Path(__file__).parents[2]


@pytest.mark.parametrize("n, noun, text", [
    (0, "atom", "0 atoms"), (1, "atom", "1 atom"), (2, "atom", "2 atoms"), (1, "branch", "1 branch"),
    (3, "branch", "3 branches"), (1, "degree of freedom", "1 degree of freedom"),
    (2, "frozen degree of freedom", "2 frozen degrees of freedom"), (1, "entry", "1 entry"),
    (4, "entry", "4 entries"), (1.5, "point", "1.5 points"),
])
def test_counted(n: float, noun: str, text: str) -> None:
    assert counted(n, noun) == text


def test_thousands_and_plural_alone() -> None:
    assert counted(1024, "point", thousands=True) == "1,024 points" and plural("mass", 2) == "masses"


def test_one_atom_per_cell_and_one_scene() -> None:
    run = subprocess.run([sys.executable, "-m", "vibra", "validate", "crystals/argon-fcc.toml"], cwd=ROOT,
                         capture_output=True, text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stderr
    assert "1 atom per cell, 3 branches" in run.stdout and "1 atoms" not in run.stdout
    assert run.stdout.rstrip().endswith("1 scene, 0 invalid")


def test_modes_summary_says_each_thing_once() -> None:
    one = vibra.normal_modes(np.array([[2.0]]), [1.0])
    assert one.summary().splitlines()[0] == "1 mode of 1 dof by the dense path"
    summary = h2o().modes().summary()
    refined = [line for line in summary.splitlines() if line.startswith("refined:")]
    if refined:  # the refinement names its count once ("refined: 6 of 9 modes ..."), not "6 of 9: 6 of 9"
        head = refined[0].removeprefix("refined: ")
        count = head.split(" modes", 1)[0]
        assert head.count(count) == 1, summary
