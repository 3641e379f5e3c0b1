"""The documentation keeps up with the code (no kernel is compiled here).

* Every reference to the physics contract in the sources, ``docs/physics.md
  §N``, names a section that exists (a section keeps its number and anchor).
* The generated references (``docs/gen_reference.py``) report no problem: every
  key the scene-file validator accepts has a description, no description names
  a key it no longer accepts, and every bound written in the docs is the one
  the validator enforces.  ``mkdocs build --strict`` fails on the same
  problems; this test says so without mkdocs installed.
"""

from __future__ import annotations

import importlib.util
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PHYSICS = ROOT / "docs" / "physics.md"
SOURCES = ("src", "tests", "studies", "benchmarks")


def _generator():
    spec = importlib.util.spec_from_file_location("rampwork_docs_gen_reference",
                                                  ROOT / "docs" / "gen_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _source_files():
    for folder in SOURCES:
        yield from (ROOT / folder).rglob("*.py")


def test_physics_references_name_existing_sections():
    anchors = set(re.findall(r'<a id="(s[0-9-]+)"></a>', PHYSICS.read_text(encoding="utf-8")))
    assert {"s1", "s2", "s3", "s4", "s5"} <= anchors
    cited = 0
    for path in _source_files():
        text = path.read_text(encoding="utf-8")
        assert "DESIGN" + " §" not in text, f"{path}: cite docs/physics.md §N, not the design notes"
        for section in re.findall(r"docs/physics\.md §([0-9]+(?:\.[0-9]+)*)", text):
            cited += 1
            assert "s" + section.replace(".", "-") in anchors, \
                f"{path.relative_to(ROOT)} cites docs/physics.md §{section}, which has no such section"
    assert cited >= 11


@pytest.mark.parametrize("part", ["scene-file", "variables", "families", "examples", "cli"])
def test_generated_reference_has_no_problems(part):
    text, problems = _generator().generate(part)
    assert not problems, "\n".join(problems)
    assert text.strip()


def test_scene_file_reference_lists_every_validator_key():
    from rampwork import scenefile
    from rampwork.ramps import FAMILIES

    text, _ = _generator().generate("scene-file")
    keys = (scenefile.TOP_KEYS + scenefile.FRICTION_KEYS + scenefile.DRAG_KEYS
            + scenefile.INTEGRATOR_KEYS + scenefile.RECORD_KEYS + scenefile.SWEEP_KEYS)
    for family in FAMILIES.values():
        keys += family.parameter_names + family.data_names
    for key in keys:
        assert f"`{key}`" in text or f"`[{key}]`" in text or f"`[sweep.{key}]`" in text, key


def test_a_missing_description_is_a_problem(monkeypatch):
    generator = _generator()
    monkeypatch.delitem(generator.DESCRIPTIONS, "integrator.dt")
    monkeypatch.setitem(generator.BOUNDS, "m", ("> 1", [(0.5, False)], {}))
    _, problems = generator.generate("scene-file")
    assert any("'integrator.dt'" in p and "no description" in p for p in problems)
    assert any("m = 0.5" in p for p in problems)
