"""A Griffe extension for the API reference: rampwork's docstrings are written
for Sphinx-style readers (``:class:`~rampwork.scene.Scene```, ``::`` before a
literal block); the reference renders them as Markdown. Roles become code
spans (``~`` keeps the last name, as Sphinx shows it) and a paragraph's
trailing ``::`` becomes ``:`` (the indented block after it is a code block
in Markdown too)."""

from __future__ import annotations

import re

from griffe import Extension

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj|const):`(~?)([^`]+)`")


def _role(match: re.Match) -> str:
    tilde, target = match.groups()
    return f"`{target.rsplit('.', 1)[-1] if tilde else target}`"


def markdown_of(text: str) -> str:
    text = _ROLE.sub(_role, text)
    lines = []
    for line in text.split("\n"):
        if line.strip() == "::":
            continue
        if line.endswith("::"):
            line = line[:-1]
        lines.append(line)
    return "\n".join(lines)


class RstRoles(Extension):
    """Docstrings' Sphinx roles and ``::`` as Markdown."""

    def on_object(self, *, obj, **kwargs):  # noqa: ARG002 - griffe's signature
        if not obj.is_alias and obj.docstring is not None:
            obj.docstring.value = markdown_of(obj.docstring.value)
