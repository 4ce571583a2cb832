"""Every docstring example in the package runs and prints what it says.

The examples are documentation a user copies; this runs each module's examples with
`doctest` (ELLIPSIS and NORMALIZE_WHITESPACE, nothing looser), so an example whose output
drifted from the code fails here. Modules are found by walking the package, so a new module
or a split into a subpackage is covered without editing this file.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import numpy as np
import pytest

import vibra

MODULES = sorted(info.name for info in pkgutil.walk_packages(vibra.__path__, prefix="vibra.")
                 if not info.name.endswith("__main__"))

#: Stages whose public functions a user meets first: each must show at least one example.
MUST_HAVE_EXAMPLES = ("vibra.modes", "vibra.system", "vibra.chains", "vibra.continuum", "vibra.crystals", "vibra.response",
                      "vibra.molecules", "vibra.spectra", "vibra.mechanics.lagrangian", "vibra.mechanics.pendulum",
                      "vibra.mechanics.rigid", "vibra.dynamics",
                      "vibra.units")


def _examples(name: str) -> list[doctest.DocTest]:
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    return [test for test in finder.find(module, name) if test.examples]


def _examples_under(name: str) -> int:
    """Number of examples in module `name` and, for a subpackage, in its modules."""
    return sum(len(test.examples) for module in MODULES if module == name or module.startswith(name + ".")
               for test in _examples(module))


def test_modules_are_found() -> None:
    """The walk must not silently parametrize over nothing."""
    assert "vibra.modes" in MODULES and len(MODULES) >= 20


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name: str) -> None:
    """Each example's printed output matches what the code prints now."""
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    with np.printoptions(legacy=False):
        for test in _examples(name):
            runner.run(test)
    results = runner.summarize(verbose=False)
    assert results.failed == 0, f"{name}: {results.failed} of {results.attempted} docstring examples failed"


@pytest.mark.parametrize("name", MUST_HAVE_EXAMPLES)
def test_user_facing_stages_have_examples(name: str) -> None:
    assert _examples_under(name) >= 1, f"{name} has no docstring example"
