"""mkdocs hooks for the pico-gym site.

- The API reference reads the code as it installs: the repository's agents/, train/ and maps/
  folders are the packages pico_gym.agents, pico_gym.train and pico_gym.maps (pyproject's
  package-dir), a layout mkdocstrings cannot be told of. It is laid out with links under
  build/api-src when mkdocs loads this file (before any page is rendered).
- The model cards (agents/models/*.md, written by `python -m pico_gym.train.ship`) link to their
  figures from the repository's agents/models/ folder; on the site they stand in agents/cards/.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
API_SRC = ROOT / "build" / "api-src"


def _lay_out() -> None:
    package = API_SRC / "pico_gym"
    if API_SRC.exists():
        shutil.rmtree(API_SRC)
    package.mkdir(parents=True)
    for entry in (ROOT / "pico_gym").iterdir():
        if entry.name != "__pycache__":
            os.symlink(entry, package / entry.name)
    for name in ("agents", "train", "maps"):
        os.symlink(ROOT / name, package / name)


_lay_out()


def on_page_markdown(markdown: str, page: Any, **kwargs: Any) -> str:
    """Pages that include a repository file (a line `--8<-- "path"`): the file, with its links to
    docs/ rewritten for where the page stands on the site."""
    out = []
    for line in markdown.splitlines():
        if not line.startswith("--8<-- "):
            out.append(line)
            continue
        included = ROOT / line.split('"')[1]
        text = included.read_text()
        # a link from the included file's folder to docs/X is, from the page, a link to X
        up = "../" * (len(Path(line.split('"')[1]).parts) - 1)
        down = "../" * page.file.src_uri.count("/")
        out.append(text.replace(f"]({up}docs/", f"]({down}").replace(f'src="{up}docs/', f'src="{down}'))
    return "\n".join(out) + "\n"
