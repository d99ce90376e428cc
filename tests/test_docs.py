"""The README, docs/, the model cards and the results: every relative link and image resolves; the README fits a page."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_README_LINES = 150
SET_UP_COMMANDS = ("make demo", "make test")
# [text](target) and ![alt](target); an optional "title" after the target is dropped
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^\s*(```|~~~)")
CODE_SPAN = re.compile(r"``.*?``|`[^`]*`")
EXTERNAL = re.compile(r"(?i)^(https?|mailto):")


def markdown_files() -> list[Path]:
    """The README, docs/ with its experiment pages, the model cards and the benchmarks' results."""
    return [README] + sorted((ROOT / "docs").rglob("*.md")) + sorted((ROOT / "blender_addon" / "models").glob("*.md")) \
        + sorted((ROOT / "benchmarks").rglob("*.md"))


def code_block_lines(text: str) -> list[str]:
    """The lines inside fenced code blocks."""
    inside, fenced = [], False
    for line in text.splitlines():
        if FENCE.match(line):
            fenced = not fenced
        elif fenced:
            inside.append(line)
    return inside


def links(text: str):
    """(line number, target) of every Markdown link and image outside code blocks and code spans."""
    fenced = False
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if fenced:
            continue
        # a code span in a link's text ([`a.py`](a.py)) leaves the link; a [x](y) inside a code span is no link
        for match in LINK.finditer(CODE_SPAN.sub("code", line)):
            yield number, match.group(1)


def broken_links(path: Path) -> list[str]:
    """'file:line: target' for each relative link or image of a Markdown file whose file or folder is missing."""
    broken = []
    for number, target in links(path.read_text(encoding="utf-8")):
        if EXTERNAL.match(target) or target.startswith("#"):
            continue
        local = target.split("#", 1)[0]
        if not (path.parent / local).exists():
            name = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path.name
            broken.append(f"{name}:{number}: {target}")
    return broken


def test_every_link_and_image_in_the_readme_and_docs_resolves():
    files = markdown_files()
    assert len(files) > 1, "no docs/*.md found"
    broken = [b for path in files for b in broken_links(path)]
    assert not broken, f"{len(broken)} broken link(s) or image(s):\n" + "\n".join(broken)


def test_the_link_check_tells_a_broken_link(tmp_path):
    (tmp_path / "there.png").write_bytes(b"")
    (tmp_path / "folder").mkdir()
    page = tmp_path / "page.md"
    page.write_text("![ok](there.png) [dir](folder/) [`code`](there.png#x) [gone](missing.md#part)\n"
                    "[web](https://example.com) [mail](mailto:a@b.c) [top](#top) `[span](nowhere.md)`\n"
                    "```\n[block](inside_a_code_block.md)\n```\n", encoding="utf-8")
    assert broken_links(page) == ["page.md:1: missing.md#part"]


def test_readme_fits_on_a_page_and_keeps_the_set_up_commands():
    text = README.read_text(encoding="utf-8")
    count = len(text.splitlines())
    assert count <= MAX_README_LINES, f"README.md has {count} lines, at most {MAX_README_LINES}"
    code = code_block_lines(text)
    missing = [c for c in SET_UP_COMMANDS if not any(line.startswith(c + " ") for line in code)]
    assert not missing, f"README.md has no code block line starting with {missing}"
