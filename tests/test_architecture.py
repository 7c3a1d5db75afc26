"""Architecture rules that keep an effect in one file (issue 14).

No code outside ``postproc/model/effects/`` names an effect: no string that is an effect's name,
one of its parameter names (``"thermal.alpha"``, ``f"base_frame.r{ax}"``) or a spec with
options (``"joint_harmonics[..."``). The rest of postproc reaches effects only through the
Effect interface, so adding an effect is adding one file. Prose (help texts, messages,
docstrings that mention an effect in a sentence) and user-level recipes such as a
default ``--effects`` list are not code that branches on a name and are not matched.
"""

from __future__ import annotations

import re
from pathlib import Path

import postproc
from postproc.model.effects import CATALOG

PACKAGE = Path(postproc.__file__).parent
EFFECTS_DIR = PACKAGE / "effects"


def _names() -> set[str]:
    """Effect names and the prefixes of their parameter names (e.g. 'compliance', shared by two effects)."""
    robot = postproc.load_robot("kr160_r1570")
    names = set(CATALOG)
    for cls in CATALOG.values():
        try:
            effect = cls()
            names |= {p.name.split(".")[0] for p in effect.params(robot)}
        except Exception:  # an effect that needs options to list its parameters: its name is enough
            continue
    return names


def _pattern(names: set[str]) -> re.Pattern:
    alternatives = "|".join(sorted(map(re.escape, names), key=len, reverse=True))
    # A string literal (any prefix: f, r, b) that starts with a name and then ends, or
    # continues with '.' (a parameter) or '[' (options).
    return re.compile(rf"""(?<![\w])[fFrRbBuU]{{0,2}}(["'])({alternatives})(\1|\.|\[)""")


def offenders(source: str, pattern: re.Pattern) -> list[tuple[int, str]]:
    return [(source.count("\n", 0, m.start()) + 1, m.group(0)) for m in pattern.finditer(source)]


def test_scanner_finds_what_it_must_and_nothing_else():
    pattern = _pattern({"backlash", "thermal", "base_frame", "compliance"})
    caught = [
        'if effects.get("backlash") is not None:',
        "if e.name == 'thermal':",
        'x = model.value(f"base_frame.r{ax}")',
        'p.name.startswith("compliance.")',
        'parse_effects("thermal[reference=21]")',
    ]
    for line in caught:
        assert offenders(line, pattern), line
    allowed = [
        'help="Cell temperature (models with a thermal effect)."',
        '"""Growth of link lengths: see ``thermal``."""',
        'name = "backlash_free"',
        'default="geometric,base_frame,tool_offset"',
    ]
    for line in allowed:
        assert not offenders(line, pattern), line


def test_no_effect_is_named_outside_the_effects_package():
    pattern = _pattern(_names())
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if EFFECTS_DIR in path.parents:
            continue
        found += [f"{path.relative_to(PACKAGE.parent)}:{line}: {text}" for line, text in offenders(path.read_text(encoding="utf-8"), pattern)]
    assert not found, "effects named outside postproc/model/effects/ (go through the Effect interface):\n" + "\n".join(found)


def test_every_catalog_effect_declares_its_interface():
    robot = postproc.load_robot("kr160_r1570")
    for name, cls in CATALOG.items():
        assert cls.summary and cls.finding and cls.identifiability, f"{name}: summary, finding and identifiability notes"
        assert cls.__module__.endswith("." + name), f"{name} lives in postproc/model/effects/{name}.py"
        effect = cls.from_options({})
        if effect.resolved:
            assert effect.params(robot), f"{name} declares its parameters"
