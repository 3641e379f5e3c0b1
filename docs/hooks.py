"""MkDocs hooks of the rampwork docs (``hooks:`` in mkdocs.yml).

1. **Generated parts.** A line ``<!-- generated: PART -->`` in a page is
   replaced by that part of ``docs/gen_reference.py`` (the scene-file
   reference from the validator's tables, the dataset variables from the
   schema registry, the ramp families, the CLI's help, the example scenes).
   What the generator reports as a problem (a key without a description, a
   documented bound the validator does not enforce) is logged as a warning,
   so ``mkdocs build --strict`` fails on it.

2. **Files of the repository outside docs/.** Pages link to figures, scripts
   and READMEs where they live in the repository (``../studies/gallery/x.png``),
   so that the Markdown files read correctly on a code host too. Every such
   file that a page links to is added to the site under its repository path,
   and the links are rewritten to point at it; linked Markdown files become
   pages themselves (and their own links are followed likewise).
"""

from __future__ import annotations

import importlib.util
import logging
import os
import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File

log = logging.getLogger("mkdocs.hooks.rampwork")

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

_MARKER = re.compile(r"^<!-- generated: ([a-z0-9-]+) -->[ \t]*$", re.MULTILINE)
#: inline links and images: [text](target) / ![alt](target "title")
_LINK = re.compile(r"(\]\()([^)\s]+)((?:\s+\"[^\"]*\")?\))")
#: folders never published, even if linked
_PRIVATE = (".git", ".venv", "site")

_generator = None
_generated: dict[str, str] = {}


def _gen():
    global _generator
    if _generator is None:
        spec = importlib.util.spec_from_file_location("rampwork_docs_gen_reference",
                                                      DOCS / "gen_reference.py")
        _generator = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(_generator)
    return _generator


def _part(name: str, page: str) -> str:
    if name not in _generated:
        try:
            text, problems = _gen().generate(name)
        except KeyError as error:
            log.warning("%s: %s", page, error.args[0])
            return ""
        for problem in problems:
            log.warning("generated reference %r: %s", name, problem)
        _generated[name] = text
    return _generated[name]


def _repo_target(source: Path, target: str) -> Path | None:
    """The repository file outside docs/ that ``target`` (a link in the file
    ``source``) points to, or None."""
    if "://" in target or target.startswith(("#", "/", "mailto:")):
        return None
    path = target.split("#", 1)[0]
    if not path:
        return None
    resolved = Path(os.path.normpath(source.parent / path))
    try:
        relative = resolved.relative_to(ROOT)
    except ValueError:
        return None
    if relative.parts[0] in _PRIVATE or resolved.is_relative_to(DOCS) or not resolved.is_file():
        return None
    return resolved


def _docs_target(source: Path, target: str) -> str | None:
    """The docs/ file (as its URI in the site) that ``target``, a link in a
    repository file outside docs/, points to, or None."""
    if "://" in target or target.startswith(("#", "/", "mailto:")):
        return None
    path = target.split("#", 1)[0]
    resolved = Path(os.path.normpath(source.parent / path)) if path else None
    if resolved is None or not resolved.is_relative_to(DOCS) or not resolved.is_file():
        return None
    return resolved.relative_to(DOCS).as_posix()


def on_startup(command, dirty):  # noqa: ARG001 - mkdocs's signature
    _generated.clear()


def on_files(files, config):
    """Add the repository files that pages link to (and, for linked Markdown
    files, what they link to in turn)."""
    queue = [Path(f.abs_src_path) for f in files.documentation_pages()]
    added = set()
    while queue:
        source = queue.pop()
        text = source.read_text(encoding="utf-8")
        for match in _LINK.finditer(text):
            target = _repo_target(source, match.group(2))
            if target is None or target in added:
                continue
            added.add(target)
            uri = target.relative_to(ROOT).as_posix()
            if files.get_file_from_path(uri) is None:
                files.append(File(uri, str(ROOT), config["site_dir"], config["use_directory_urls"]))
            if target.suffix == ".md":
                queue.append(target)
    return files


def on_page_markdown(markdown, page, config, files):  # noqa: ARG001 - mkdocs's signature
    markdown = _MARKER.sub(lambda m: _part(m.group(1), page.file.src_uri), markdown)
    source = Path(page.file.abs_src_path)
    here = posixpath.dirname(page.file.src_uri)

    def rewrite(match):
        target = match.group(2)
        repo_file = _repo_target(source, target)
        if repo_file is not None:
            uri = repo_file.relative_to(ROOT).as_posix()
        elif not source.is_relative_to(DOCS) and (page_in_docs := _docs_target(source, target)):
            uri = page_in_docs  # a repository page's link into docs/
        else:
            return match.group(0)
        fragment = "#" + target.split("#", 1)[1] if "#" in target else ""
        return f"{match.group(1)}{posixpath.relpath(uri, here or '.')}{fragment}{match.group(3)}"

    return _LINK.sub(rewrite, markdown)
