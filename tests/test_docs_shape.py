"""The docs read as a product's: model cards in Mitchell et al.'s sections, limits on a page, the lab notebook apart."""

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CARDS = sorted((ROOT / "blender_addon" / "models").glob("*.md"))
EXPERIMENTS = ROOT / "docs" / "experiments"
LIMITS = ROOT / "docs" / "limits.md"
MAX_CARD_LINES, MAX_LIMITS_LINES, MAX_LIMIT_LINES = 150, 120, 4
# Mitchell et al., "Model Cards for Model Reporting" (2019), section 4, in its order.
CARD_SECTIONS = ["Model details", "Intended use", "Factors", "Metrics", "Evaluation data", "Training data",
                 "Quantitative analyses", "Ethical considerations", "Caveats and recommendations"]
# The work's own diary has no place in the product's files; dates do. (Spelt in two parts so this file passes.)
NARRATION = re.compile(r"(?i)\bsess" + r"ion[\s_-]*[0-9]")
RESULT_LINK = re.compile(r"\]\((?:\.\./)+benchmarks/results/[\w.-]+\.md[^)]*\)")
ENTRY = re.compile(r"^### (\d{4}-\d{2}-\d{2})\b")


def headings(text: str, level: int = 2) -> list[str]:
    """The titles of a Markdown page's headings of one level, in order (fenced code left out)."""
    marker, fenced, found = "#" * level + " ", False, []
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced and line.startswith(marker):
            found.append(line[len(marker):].strip())
    return found


def section(text: str, title: str) -> str:
    """The body of the level-2 section `title` (up to the next level-2 heading)."""
    match = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", text, re.M | re.S)
    return match.group(1) if match else ""


def bullets(text: str) -> list[list[str]]:
    """Each top-level '- ' bullet of a page with its continuation lines."""
    items: list[list[str]] = []
    current = None
    for line in text.splitlines():
        if line.startswith("- "):
            current = [line]
            items.append(current)
        elif current is not None and line.startswith("  ") and line.strip():
            current.append(line)
        else:
            current = None
    return items


def tracked_texts() -> dict[Path, str]:
    """Every file git tracks that reads as UTF-8 text, with its text."""
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    texts = {}
    for name in filter(None, listed.decode().split("\0")):
        path = ROOT / name
        try:
            data = path.read_bytes()
        except (FileNotFoundError, IsADirectoryError):
            continue
        if b"\0" not in data[:8192]:
            try:
                texts[path] = data.decode("utf-8")
            except UnicodeDecodeError:
                continue
    return texts


def narration(text: str) -> list[str]:
    """The lines of a text that narrate the work by its sessions."""
    return [line.strip() for line in text.splitlines() if NARRATION.search(line)]


def test_every_shipped_model_has_a_card_of_at_most_150_lines_in_the_layouts_sections():
    shipped = {p.stem for p in (ROOT / "blender_addon" / "models").glob("*_encoder.onnx")}
    assert shipped <= {c.stem for c in CARDS}, "an encoder ships without its card"
    for card in CARDS:
        text = card.read_text(encoding="utf-8")
        count = len(text.splitlines())
        assert count <= MAX_CARD_LINES, f"{card.name} has {count} lines, at most {MAX_CARD_LINES}"
        assert text.startswith("# Model card: "), card.name
        assert headings(text) == CARD_SECTIONS, f"{card.name}: sections {headings(text)}"


def test_every_cards_figures_link_to_the_benchmark_that_produced_them():
    for card in CARDS:
        figures = section(card.read_text(encoding="utf-8"), "Quantitative analyses")
        assert re.search(r"\d", figures), f"{card.name} quotes no figure"
        assert RESULT_LINK.search(figures), f"{card.name}'s figures link to no benchmarks/results page"


def test_the_experiments_are_a_page_per_product_of_findings_and_dated_entries():
    pages = sorted(EXPERIMENTS.glob("*.md"))
    assert {"lipstick.md", "eyeshadow.md", "hair.md"} <= {p.name for p in pages}
    for page in pages:
        text = page.read_text(encoding="utf-8")
        assert headings(text)[:2] == ["Findings", "Entries"], f"{page.name}: {headings(text)}"
        dates = [m.group(1) for line in text.splitlines() if (m := ENTRY.match(line))]
        assert dates and dates == sorted(dates, reverse=True), f"{page.name}: entries not dated newest first"


def test_limits_fit_on_a_page_each_in_at_most_four_lines():
    text = LIMITS.read_text(encoding="utf-8")
    count = len(text.splitlines())
    assert count <= MAX_LIMITS_LINES, f"docs/limits.md has {count} lines, at most {MAX_LIMITS_LINES}"
    limits = bullets(text)
    assert len(limits) >= 5
    long = [item[0][:60] for item in limits if len(item) > MAX_LIMIT_LINES]
    assert not long, f"limits over {MAX_LIMIT_LINES} lines: {long}"


def test_the_bullet_reader_counts_a_limits_continuation_lines():
    page = "# T\n\n- one\n  two\n  three\n- four\n\n## Part\n\n- five\n  six\n"
    assert bullets(page) == [["- one", "  two", "  three"], ["- four"], ["- five", "  six"]]


def test_no_tracked_file_narrates_the_work_by_sessions():
    texts = tracked_texts()
    assert len(texts) > 100
    found = [f"{p.relative_to(ROOT)}: {line[:80]}" for p, text in texts.items() for line in narration(text)]
    assert not found, f"{len(found)} line(s):\n" + "\n".join(found[:20])


def test_the_narration_check_tells_a_session_from_its_neighbours():
    said = "s" + "ession"
    assert narration(f"the {said} 82 run\nThe {said.title()}-60 file\n({said}_7)")
    assert not narration("an onnxruntime InferenceSession\nsessions[i] = 2\n2026-12-06 (the r82 run)")


def test_every_benchmark_and_script_is_listed_where_a_reader_looks():
    """benchmarks/ and scripts/ hold what is maintained: each is in docs/benchmarks.md or docs/layout.md."""
    listed = (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8") + \
        (ROOT / "docs" / "layout.md").read_text(encoding="utf-8")
    kept = sorted((ROOT / "benchmarks").glob("bench_*.py")) + sorted((ROOT / "scripts").glob("*.*"))
    unlisted = [p.name for p in kept if p.stem not in listed]
    assert not unlisted, f"not in docs/benchmarks.md or docs/layout.md: {unlisted}"
