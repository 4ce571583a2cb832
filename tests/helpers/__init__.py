"""Helpers shared by test modules (issue 43): a test module imports them from here, never from
another test module. ``tests/`` is on sys.path under pytest's default import mode, so
``from helpers.rings import ring_count`` works from any test file.

- `helpers.springs`: spring networks and lattices with their closed-form or 50-digit truth;
- `helpers.chains`: chains and their Sturm counts;
- `helpers.rings`: rings (free and walled) and their exact counts;
- `helpers.images`: checks that a PNG was written, has its size and is not blank;
- `helpers.package`: facts about the package (its bundled scene folders, its heavy imports);
- `helpers.browser`: the Chromium the browser tests drive, and canvas pixels.
- `helpers.forked`: a function run in a forked child, its exit status and what it returned.
- `helpers.assemblies`: the iterative path's benchmark assembly (copies of ubiquitin, ANM);
- `helpers.fake_cupy`: a numpy stand-in for CuPy on which a host/device slip raises as on a GPU.
"""
