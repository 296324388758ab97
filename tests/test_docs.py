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


def _docs_hooks():
    """``docs/hooks.py``, the site's build hooks, as a module (it is no part of the package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_public_module_has_its_api_entry():
    """What ``mkdocs build --strict`` (run by the README's test command) also refuses, said here first."""
    assert _docs_hooks().undocumented_modules() == []


def test_a_module_without_an_entry_is_found(tmp_path):
    api = tmp_path / "api"
    api.mkdir()
    for page in (ROOT / "docs" / "api").glob("*.md"):
        text = page.read_text(encoding="utf-8").replace("::: casadi_sins.core.signals\n", "")
        (api / page.name).write_text(text, encoding="utf-8")
    assert _docs_hooks().undocumented_modules(tmp_path) == ["casadi_sins.core.signals"]
