"""Griffe extension for the API pages: the package's own docstring conventions, in Markdown.

The code documents in NumPy style, with habits from Sphinx and reST that mkdocstrings does not read:

* ``#:`` comments above a module or class attribute are its docstring (``#: Earth rate, rad/s.``);
  here they become the attribute's docstring, so that constants such as ``NAMES`` are documented;
* a paragraph of prose after the entries of a ``Parameters`` (``Attributes``, ``Raises``) section
  without a section header of its own would be read as more entries (a parameter named ``The``);
  here it gets a ``Notes`` header, and the build lists it (``INFO``) so that the docstring can be
  fixed in the code;
* two reST forms read as Markdown: a paragraph ending in ``::`` before a literal block ends in
  ``:`` (the indented block stays a code block), and a definition list (a term line followed
  directly by an indented definition) becomes a Markdown definition list;
* Sphinx roles (``:func:`calibrate```, ``:mod:`noise.kalman```, ``:class:`~core.errors.InputError```)
  name other objects, relative to the package or to the module they are in; here each becomes a
  link to that object's entry in the API pages when the pages show it, and a code span otherwise.

A role whose target cannot be found from where it stands, but whose name ends exactly one object of
the package, links to that object; a role naming nothing becomes a code span.  Both are listed in
the build's output (``INFO``, not a warning: the text still reads well), so that stale names in
docstrings can be fixed in the code.

Loaded by ``mkdocs.yml`` (``plugins.mkdocstrings.handlers.python.options.extensions``).
"""

from __future__ import annotations

import logging
import re

import griffe

LOG = logging.getLogger("mkdocs.plugins.griffe_conventions")
ROLE = re.compile(r":(?:py:)?(?:mod|func|class|meth|data|attr|obj|exc|const):`(~?)([^`<>]+?)`")
#: Sections whose entries are names (``name : type`` and an indented description).
ENTRY_SECTIONS = {"parameters", "other parameters", "attributes", "raises", "warns", "receives"}
ENTRY = re.compile(r"^\*{0,2}[A-Za-z_]\w*(\s*,\s*\*{0,2}[A-Za-z_]\w*)*(\s*:.*)?$")
KINDS = (griffe.Kind.MODULE, griffe.Kind.CLASS, griffe.Kind.FUNCTION, griffe.Kind.ATTRIBUTE)


def _walk(obj):
    """The object and every member defined under it (no aliases: they are documented where defined)."""
    yield obj
    for member in obj.members.values():
        if not member.is_alias:
            yield from _walk(member)


def _comment_docstring(obj) -> str | None:
    """The ``#:`` comment lines right above an attribute, joined, or ``None``."""
    if obj.filepath is None or obj.lineno is None:
        return None
    try:
        lines = obj.lines_collection[obj.filepath]
    except KeyError:
        return None
    found = []
    index = obj.lineno - 2
    while index >= 0 and lines[index].strip().startswith("#:"):
        found.append(lines[index].strip()[2:].strip())
        index -= 1
    return "\n".join(reversed(found)) or None


def _prose_as_notes(text: str) -> tuple[str, bool]:
    """Give a ``Notes`` header to prose that follows the entries of a Parameters-like section."""
    lines = text.split("\n")
    out: list[str] = []
    section = ""
    changed = False
    for k, line in enumerate(lines):
        following = lines[k + 1] if k + 1 < len(lines) else ""
        if line.strip() and set(following.strip()) == {"-"} and len(following.strip()) >= 3:
            section = line.strip().lower()
        elif (section in ENTRY_SECTIONS and line.strip() and not line[0].isspace() and k > 0
              and not lines[k - 1].strip() and not ENTRY.match(line.strip()) and set(line.strip()) != {"-"}):
            out += ["Notes", "-----"]
            section = "notes"
            changed = True
        out.append(line)
    return "\n".join(out), changed


LIST_ITEM = re.compile(r"^(?:[*+-]|\d+[.)])\s")
SECTION_RULE = re.compile(r"^\s*-{3,}\s*$")


def _rest_to_markdown(text: str) -> str:
    """``::`` literal-block markers and definition lists, in the free text before the first section."""
    lines = text.split("\n")
    end = next((k - 1 for k in range(1, len(lines)) if SECTION_RULE.match(lines[k]) and lines[k - 1].strip()),
               len(lines))
    out: list[str] = []
    k = 0
    after_definition = False
    while k < end:
        line = lines[k]
        if line.strip() == "::":
            k += 1
            continue
        if line.rstrip().endswith("::"):
            out.append(line.rstrip()[:-1])
            k += 1
            continue
        following = lines[k + 1] if k + 1 < end else ""
        if (line.strip() and not line[0].isspace() and not LIST_ITEM.match(line) and following.strip()
                and following[0].isspace() and (k == 0 or not lines[k - 1].strip() or after_definition)):
            body = []
            k += 1
            while k < end and (not lines[k].strip() or lines[k][0].isspace()):
                body.append(lines[k])
                k += 1
            while body and not body[-1].strip():
                body.pop()
            indent = min(len(b) - len(b.lstrip()) for b in body if b.strip())
            body = [b[indent:] for b in body]
            out += [line, ":   " + body[0]] + [("    " + b) if b.strip() else "" for b in body[1:]] + [""]
            after_definition = True
            continue
        after_definition = False
        out.append(line)
        k += 1
    return "\n".join(out + lines[end:])


def _shown(obj) -> bool:
    """Whether the API pages render the object: public and documented, and so is every parent."""
    if obj.kind not in KINDS or obj.is_alias:
        return False
    node = obj
    while node is not None:
        if node.name.startswith("_"):
            return False
        if not node.is_module and not node.has_docstring:
            return False
        node = node.parent
    return True


class SphinxConventions(griffe.Extension):
    """``#:`` attribute comments become docstrings; Sphinx roles become links or code spans."""

    def __init__(self) -> None:
        super().__init__()
        self.unresolved: list[tuple[str, str, str | None]] = []  # (owner, role target, found by ending)
        self._done: set[str] = set()
        self._all: list | None = None

    def on_package(self, *, pkg: griffe.Module, **kwargs) -> None:
        """Rewrite every docstring of the package once it is loaded."""
        if pkg.path in self._done:
            return
        self._done.add(pkg.path)
        objects = list(_walk(pkg))
        for obj in objects:
            if obj.is_attribute and obj.docstring is None:
                text = _comment_docstring(obj)
                if text:
                    obj.docstring = griffe.Docstring(text, parent=obj)
        for obj in objects:
            if obj.docstring is None:
                continue
            value, changed = _prose_as_notes(_rest_to_markdown(obj.docstring.value))
            if changed:
                LOG.info("docstring of %s: prose after the entries of a section, shown under 'Notes'", obj.path)
            obj.docstring.value = ROLE.sub(lambda m, o=obj: self._replace(o, pkg, m), value)
        for owner, target, found in self.unresolved:
            if found is None:
                LOG.info("docstring of %s names %r, which is not in the package", owner, target)
            else:
                LOG.info("docstring of %s names %r, found only as %s", owner, target, found)

    def _replace(self, owner, pkg, match) -> str:
        short, target = match.group(1) == "~", match.group(2).strip()
        text = target.split(".")[-1] if short else target.lstrip(".")
        found = self._resolve(owner, pkg, target)
        if found is None:
            found = self._by_ending(pkg, target)
            self.unresolved.append((owner.path, target, found and found.path))
        if found is None:
            return f"`{text}`"
        if not _shown(found):
            return f"`{text}`"
        return f"[`{text}`][{found.path}]"

    def _by_ending(self, pkg, target: str):
        """The one object of the package whose path ends with ``.target`` (``None`` if none or several)."""
        if self._all is None:
            self._all = [o for o in _walk(pkg) if o.kind in KINDS]
        ending = "." + target.lstrip(".")
        matches = [o for o in self._all if o.path.endswith(ending)]
        return matches[0] if len(matches) == 1 else None

    @staticmethod
    def _resolve(owner, pkg, target: str):
        """The object a role names: relative to the owner's module (a leading dot: to its package),
        to its class, to each enclosing package, or to the package root."""
        module = owner if owner.is_module else owner.module
        candidates = []
        if target.startswith("."):
            base = module if module.is_init_module else module.parent
            stripped = target.lstrip(".")
            for _ in range(len(target) - len(stripped) - 1):
                base = base.parent
            candidates.append(f"{base.path}.{stripped}")
        else:
            if not owner.is_module and owner.parent is not None and owner.parent.is_class:
                candidates.append(f"{owner.parent.path}.{target}")
            node = module
            while node is not None:
                candidates.append(f"{node.path}.{target}")
                node = node.parent
            candidates.append(target)
        root = pkg.path
        for path in candidates:
            if path != root and not path.startswith(root + "."):
                continue
            try:
                found = pkg if path == root else pkg[path[len(root) + 1:]]
            except (KeyError, ValueError, griffe.AliasResolutionError, griffe.CyclicAliasError):
                continue
            if found.is_alias:
                try:
                    found = found.final_target
                except (griffe.AliasResolutionError, griffe.CyclicAliasError):
                    continue
            return found
        return None
