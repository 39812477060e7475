"""The generated part of a docs page: the text between `<!-- NAME:begin -->` and
`<!-- NAME:end -->`, which a benchmark replaces with what it measured (the rest of the page is
written by hand)."""

from __future__ import annotations

import re
from pathlib import Path


def replace_section(doc: Path, name: str, body: str) -> None:
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    text = doc.read_text()
    new = f"{begin}\n{body}\n{end}"
    doc.write_text(re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda _: new, text, flags=re.S))
