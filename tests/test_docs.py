"""The README and the docs stand on their own: every link to a file points into the repository."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def test_readme_and_docs_link_only_to_files_in_the_repository():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("**/*.md"))]
    assert len(pages) > 5
    for page in pages:
        text = page.read_text(encoding="utf-8")
        assert "../shared" not in text and "shared/spec" not in text, page
        for target in LINK.findall(text):
            if re.match(r"[a-z]+:", target):  # a URL: none in our pages but the references' DOIs
                continue
            assert (page.parent / target).resolve().exists(), (page.name, target)
