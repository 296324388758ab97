"""MkDocs hooks of the documentation (``hooks:`` in ``mkdocs.yml``).

* The command-line reference is generated from the argument parser itself
  (:func:`casadi_sins.cli.parser.build_parser`): the marker ``<!-- cli-reference -->`` in
  ``cli.md`` becomes one section per command, with its usage and every argument's help.  It cannot
  fall behind the code.
* Every repository path a page names in a code span (``results/...``, ``problems/...``,
  ``tests/...``, ``benchmarks/...``, ``casadi_sins/...``, ``docs/...``; ``*`` allowed) must exist,
  and every public module of the package must have a ``::: casadi_sins...`` entry on an API page;
  otherwise the build warns (an error under ``mkdocs build --strict``).
* No page may point outside the repository (``../`` above the repository root).
* Equations: ``$$ ... $$`` (a block on lines of its own) and ``\\( ... \\)`` (inline) in LaTeX are
  typeset as MathML when the site is built (``latex2mathml``), which browsers render themselves: no
  script and nothing fetched from outside, as for the fonts.
"""

from __future__ import annotations

import argparse
import glob
import logging
import os
import re
import sys
from pathlib import Path

LOG = logging.getLogger("mkdocs.hooks.casadi_sins")
ROOT = Path(__file__).resolve().parent.parent
PATH_SPAN = re.compile(r"`((?:results|problems|tests|benchmarks|casadi_sins|docs)/[^`\s]*)`")
API_ENTRY = re.compile(r"^:::\s+(casadi_sins[\w.]*)", re.MULTILINE)
MARKER = "<!-- cli-reference -->"


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Generate the CLI reference, and check the repository paths a page names."""
    for path in PATH_SPAN.findall(markdown):
        if not glob.glob(str(ROOT / path.rstrip("/"))):
            LOG.warning("%s names %s, which is not in the repository", page.file.src_path, path)
    for target in re.findall(r"\]\(([^)\s]+)\)", markdown):
        if target.startswith("../") and not (Path(config["docs_dir"]) / Path(page.file.src_path).parent / target
                                             ).resolve().is_relative_to(ROOT):
            LOG.warning("%s links to %s, outside the repository", page.file.src_path, target)
    if MARKER in markdown:
        markdown = markdown.replace(MARKER, cli_reference())
    return typeset_math(markdown)


FENCE = re.compile(r"^(```|~~~).*?^\1[ \t]*$", re.MULTILINE | re.DOTALL)
DISPLAY = re.compile(r"^\$\$[ \t]*\n(.+?)\n\$\$[ \t]*$", re.MULTILINE | re.DOTALL)
INLINE = re.compile(r"\\\((.+?)\\\)")


def typeset_math(markdown: str) -> str:
    """LaTeX ``$$ ... $$`` blocks and ``\\( ... \\)`` spans as MathML, outside fenced code."""
    from latex2mathml.converter import convert

    def block(match):
        return "\n" + convert(" ".join(match.group(1).split()), display="block") + "\n"

    def inline(match):
        return convert(match.group(1))

    parts, last = [], 0
    for fence in FENCE.finditer(markdown):
        parts.append(INLINE.sub(inline, DISPLAY.sub(block, markdown[last:fence.start()])))
        parts.append(fence.group(0))
        last = fence.end()
    parts.append(INLINE.sub(inline, DISPLAY.sub(block, markdown[last:])))
    return "".join(parts)


def undocumented_modules(docs_dir: Path = ROOT / "docs") -> list[str]:
    """The package's public modules (every module and package below ``casadi_sins/`` whose dotted name has no
    part starting with ``_``) that no ``::: casadi_sins...`` entry on a page of ``docs_dir/api`` documents."""
    documented = set()
    for page in (Path(docs_dir) / "api").glob("*.md"):
        documented.update(API_ENTRY.findall(page.read_text(encoding="utf-8")))
    missing = []
    for source in sorted((ROOT / "casadi_sins").rglob("*.py")):
        parts = source.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if any(p.startswith("_") for p in parts):
            continue
        name = ".".join(parts)
        if name not in documented:
            missing.append(name)
    return missing


def on_post_build(config) -> None:
    """Warn about public modules that no API page documents."""
    for name in undocumented_modules(Path(config["docs_dir"])):
        LOG.warning("module %s has no '::: %s' entry on any page of docs/api/", name, name)


def _argument_row(action: argparse.Action) -> str:
    """One table row: the argument as typed, and its help."""
    if action.option_strings:
        name = ", ".join(action.option_strings)
        if action.nargs != 0:
            metavar = action.metavar or (
                "{" + ",".join(map(str, action.choices)) + "}" if action.choices else action.dest.upper())
            name += f" {metavar}" + (" ..." if action.nargs in ("+", "*") else "")
    else:
        name = action.metavar or action.dest
        name += " ..." if action.nargs in ("+", "*") else ""
        name = f"[{name}]" if action.nargs in ("?", "*") else name
    text = (action.help or "").replace("|", "\\|")
    if action.option_strings and action.required:
        text = "required: " + text
    return f"| `{name}` | {text} |"


def _usage(parser: argparse.ArgumentParser) -> str:
    """The usage line(s) of a parser without the ``usage:`` prefix and its indentation."""
    lines = parser.format_usage().strip().removeprefix("usage: ").splitlines()
    return "\n".join([lines[0]] + ["    " + line.strip() for line in lines[1:]])


def cli_reference() -> str:
    """Markdown sections of every command of ``casadi-sins``, from its argument parser."""
    if str(ROOT) not in sys.path:  # the checkout's package, installed or not
        sys.path.insert(0, str(ROOT))
    from casadi_sins.cli.parser import build_parser

    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        parser = build_parser()
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        helps = {a.dest: a.help for a in sub._choices_actions}
        top = [a for a in parser._actions if a is not sub and not isinstance(a, argparse._HelpAction)]
        out = ["```text", _usage(parser), "```", "", "| argument | meaning |", "| --- | --- |",
               *[_argument_row(a) for a in top], "| `COMMAND` | one of the commands below |", ""]
        for name, command in sub.choices.items():
            rows = [_argument_row(a) for a in command._actions if not isinstance(a, argparse._HelpAction)]
            out += [f"### `{name}`", "", (helps.get(name) or "").capitalize() + ".", "", "```text",
                    _usage(command), "```", "", "| argument | meaning |", "| --- | --- |", *rows, ""]
        return "\n".join(out)
    finally:
        if saved is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = saved
