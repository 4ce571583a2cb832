"""Every python block of the docs pages without a test of their own runs alone, as a reader would
paste it into a fresh script (issue 32: six blocks continued an earlier one and failed with
NameError). Each block runs in a scratch folder where the bundled scene folders are visible,
as ``__main__`` (the Dask examples carry the ``if __name__ == "__main__":`` guard a script
needs). A block whose first line says ``# not run:`` (a cluster, a scheduler) is only compiled.
The pages with their own tests (compare, crystals, dynamics, response, spectra) are covered
there; docs/networks.md runs here, without ProDy, on the repository's own PDB file (issue 48)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[2]
PAGES = ("chains.md", "distributed.md", "generalized.md", "index.md", "molecules.md", "networks.md", "scenes.md")
BLOCKS = [(page, index, block) for page in PAGES
          for index, block in enumerate(re.findall(r"```python\n(.*?)```", (ROOT / "docs" / page).read_text(), re.S))]


def test_the_pages_have_blocks() -> None:
    assert {page for page, _, _ in BLOCKS} >= {"distributed.md", "generalized.md", "molecules.md", "networks.md"}


@pytest.mark.parametrize("page,index,block", BLOCKS, ids=[f"{p}:{i}" for p, i, _ in BLOCKS])
def test_each_block_runs_alone(page: str, index: int, block: str, tmp_path: Path,
                               monkeypatch: pytest.MonkeyPatch) -> None:
    code = compile(block, f"docs/{page} block {index}", "exec")
    if block.startswith("# not run:"):
        return
    for folder in ("chains", "molecules", "networks"):
        (tmp_path / folder).symlink_to(ROOT / folder, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    exec(code, {"__name__": "__main__"})
