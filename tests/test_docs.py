"""The docs by audience (docs/development.md): user pages short, studies and their data in docs/studies/, the
specs the code cites in the repository, and every relative link resolving."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def test_no_top_level_docs_page_over_400_lines_and_no_large_study_data_outside_the_studies():
    long = {p.name: n for p in DOCS.glob("*.md") if (n := len(p.read_text(encoding="utf-8").splitlines())) > 400}
    assert not long, long
    big = [str(p.relative_to(ROOT)) for p in DOCS.rglob("*.json")
           if p.stat().st_size > 100_000 and DOCS / "studies" not in p.parents]
    assert not big, big


@pytest.mark.parametrize("name", ["CONVENTIONS.md", "EVALUATION.md"])
def test_the_specs_the_code_cites_are_in_the_repository_and_match_shared(name):
    here = DOCS / name
    assert here.is_file()
    shared = ROOT.parent / "shared" / name
    if shared.is_file():  # beside a checkout with ../shared (CI has it): the copy is exact
        assert here.read_bytes() == shared.read_bytes(), f"docs/{name} differs from ../shared/{name}: copy it again"


def test_every_relative_link_in_the_docs_resolves():
    broken = []
    for page in [ROOT / "README.md", *DOCS.rglob("*.md")]:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text(encoding="utf-8")):
            path = target.split("#", 1)[0]
            if not path or re.match(r"^[a-z]+:", path):
                continue
            if not (page.parent / path).exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, "\n".join(broken)
