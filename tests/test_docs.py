"""The documentation describes the code as it is: each env's page is its docstring (sections and
families), the design pages name files that exist, and the README fits on a few screens."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pico_gym import BUILTIN_TASKS
from pico_gym.registry import load_entry

ROOT = Path(__file__).resolve().parents[1]
SECTIONS = ("Description", "Observation Space", "Action Space", "Rewards", "Episode End", "Info", "Arguments")


@pytest.mark.parametrize("info", BUILTIN_TASKS, ids=lambda i: i.env_id)
def test_each_env_page_is_its_docstring_with_every_section_and_family(info) -> None:
    cls = load_entry(info.entry_point)
    doc = cls.__doc__
    headings = re.findall(r"^\s*## (.+)$", doc, flags=re.M)
    for section in SECTIONS:
        assert any(h.startswith(section) for h in headings), (info.env_id, section)
    assert headings[-1] == "Version History", info.env_id
    families = getattr(cls, "families", {})
    if families:
        assert "Families" in headings, info.env_id
        for name in families:
            assert f'"{name}"' in doc, (info.env_id, name)
    pages = [
        p for p in (ROOT / "docs" / "envs").glob("*.md") if f"::: {cls.__module__}.{cls.__name__}" in p.read_text()
    ]
    assert len(pages) == 1, (info.env_id, pages)


def test_the_design_pages_name_files_that_exist() -> None:
    for page in ("architecture.md", "adding-a-task.md", "compiled-twins.md"):
        text = (ROOT / "docs" / page).read_text()
        for path in set(re.findall(r"`((?:pico_gym|agents|train|tests)/[\w/]+\.py)`", text)):
            repo_path = path.replace("pico_gym/agents/", "agents/").replace("pico_gym/train/", "train/")
            assert (ROOT / repo_path).exists(), (page, path)


def test_the_readme_fits_on_a_few_screens() -> None:
    assert len((ROOT / "README.md").read_text().splitlines()) <= 200
