"""Every field of every message definition in msg_defs/ is documented with its unit."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

MSG_DIR = Path(__file__).resolve().parents[2] / "msg_defs" / "msg"
MSG_FILES = sorted(MSG_DIR.glob("*.msg"))
#: ``type name`` optionally followed by ``=value`` (a constant) and a ``# comment``.
FIELD = re.compile(
    r"^(?P<type>[\w/\[\]<=]+)\s+(?P<name>\w+)(?P<const>\s*=\s*[^#]+)?\s*(?:#(?P<doc>.*))?$"
)
UNIT = re.compile(r"\[[^\]]+\]")


def test_all_messages_present() -> None:
    assert {p.stem for p in MSG_FILES} == {
        "ContactState",
        "ContactStateArray",
        "DragTorque",
        "HealthResidual",
    }


@pytest.mark.parametrize("path", MSG_FILES, ids=lambda p: p.stem)
def test_every_field_has_a_comment_with_unit(path: Path) -> None:
    undocumented = []
    for raw in path.read_text(encoding="utf-8").splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        match = FIELD.match(line)
        assert match, f"{path.name}: cannot parse {line!r}"
        doc = (match["doc"] or "").strip()
        if not doc:
            undocumented.append(match["name"])
        elif match["const"] is None and match["name"] != "header" and not UNIT.search(doc):
            undocumented.append(f"{match['name']} (no [unit])")
    assert not undocumented, f"{path.name}: {undocumented}"
