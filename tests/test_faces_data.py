"""data/faces: every record names an existing file with its source and licence, the splits are disjoint by person."""

import json
import re
import struct
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FACES = ROOT / "data" / "faces"
RECORDS = json.loads((FACES / "faces.json").read_text(encoding="utf-8"))
SPLITS = {"train", "held_out", "evaluation"}
ASTRONAUT = "package:skimage.data.astronaut"
HOPPER = "package:matplotlib/grace_hopper.jpg"


def person(record: dict) -> str:
    """The subject's name: the part before the first comma ('Pamela Melroy, NASA astronaut ...')."""
    return record["subject"].split(",", 1)[0].strip().lower()


def jpeg_size(path: Path) -> tuple[int, int]:
    """(width, height) from the JPEG's start-of-frame marker, without decoding the image."""
    data = path.read_bytes()
    assert data[:2] == b"\xff\xd8", f"{path.name} is not a JPEG"
    i = 2
    while i < len(data):
        assert data[i] == 0xFF, f"{path.name}: bad marker at {i}"
        marker = data[i + 1]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            i += 2
            continue
        length = struct.unpack(">H", data[i + 2:i + 4])[0]
        if marker in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
            height, width = struct.unpack(">HH", data[i + 5:i + 9])
            return width, height
        i += 2 + length
    raise AssertionError(f"{path.name}: no start-of-frame marker")


def test_every_record_names_an_existing_file_or_a_package_photo():
    missing = [r["file"] for r in RECORDS
               if not r["file"].startswith("package:") and not (ROOT / r["file"]).is_file()]
    assert not missing, f"files not found: {missing}"
    files = [r["file"] for r in RECORDS]
    assert len(files) == len(set(files)), "a file has two records"


def test_every_record_has_its_source_licence_and_labels():
    for r in RECORDS:
        src = r.get("source")
        assert isinstance(src, dict) and src.get("repository") and src.get("path") and src.get("origin"), r["file"]
        assert {"commit", "blob", "url"} <= set(src), r["file"]
        if src["repository"] == "kling109/ISS-Archaeology":
            hashes = (src["commit"], src["blob"])
            assert all(re.fullmatch(r"[0-9a-f]{40}", h) for h in hashes), r["file"]
        assert r.get("licence", "").startswith("Public domain"), r["file"]
        assert r["split"] in SPLITS, r["file"]
        assert isinstance(r["lips_visible"], bool) and r["lipstick"] and r["lipstick_confidence"], r["file"]
        assert r.get("processing") and len(r["size"]) == 2, r["file"]


def test_new_faces_are_usa_portraits_at_the_benchmark_commit():
    new = [r for r in RECORDS if r["file"].startswith("data/faces/")]
    assert new
    for r in new:
        assert r["source"]["path"].startswith("Data/Portraits/") and "&usa." in r["source"]["path"], r["file"]
        assert r["source"]["commit"] == "3e2dd59a10d171ff669a56e0a9a7aa2fd128b416", r["file"]


def test_splits_are_disjoint_by_person():
    splits = defaultdict(set)
    for r in RECORDS:
        splits[person(r)].add(r["split"])
    mixed = {p: s for p, s in splits.items() if len(s) > 1}
    assert not mixed, f"people in two splits: {mixed}"
    portraits = [person(r) for r in RECORDS if "(official portrait" in r["subject"]]
    twice = sorted({p for p in portraits if portraits.count(p) > 1})
    assert not twice, f"people with two portraits: {twice}"


def test_the_crew_photo_shares_no_person_with_train_or_held_out():
    crew = next(r for r in RECORDS if r["file"].endswith("nasa_iss_expedition1_crew.jpg"))
    names = [n.strip().lower() for n in re.search(r"\(([^)]*)\)", crew["subject"]).group(1).split(",")]
    for r in RECORDS:
        if r["split"] != "evaluation":
            assert person(r) not in names, r["file"]


def test_at_least_twelve_held_out_and_the_package_photos_are_evaluation():
    by_file = {r["file"]: r for r in RECORDS}
    assert sum(r["split"] == "held_out" for r in RECORDS) >= 12
    assert by_file[ASTRONAUT]["split"] == "evaluation"
    assert by_file[HOPPER]["split"] == "evaluation"
    for r in json.loads((ROOT / "benchmarks/photos/photos.json").read_text(encoding="utf-8")):
        name = r["file"] if r["file"].startswith("package:") else "benchmarks/photos/" + r["file"]
        assert name in by_file, f"benchmark photo {name} has no record"
        if r.get("held_out"):
            assert by_file[name]["split"] == "held_out", name


def test_every_jpeg_here_is_small_and_has_a_record():
    recorded = {r["file"] for r in RECORDS}
    jpegs = sorted(FACES.glob("*.jp*g"))
    assert jpegs
    for path in jpegs:
        rel = path.relative_to(ROOT).as_posix()
        assert rel in recorded, f"{rel} has no record"
        assert re.fullmatch(r"nasa_[a-z_]+\.jpg", path.name), path.name
        w, h = jpeg_size(path)
        assert max(w, h) <= 800, f"{path.name} is {w} x {h}"
        record = next(r for r in RECORDS if r["file"] == rel)
        assert record["size"] == [w, h], path.name
    assert sum(p.stat().st_size for p in FACES.iterdir()) < 15 * 2**20


LONDON = json.loads((FACES / "london" / "faces.json").read_text(encoding="utf-8"))
LONDON_EVALUATION = {"black": "025 042 043 044 061 062 082 099 126 129", "east_asian": "005 024 030 034 045 067 087 119 127",
                     "west_asian": "006 008 037 038 064 066 070 115 135 142",
                     "white": "001 002 003 007 009 010 011 013 014 016"}


def test_the_london_set_is_credited_cropped_and_split_by_person():
    """Every London record names its file, source blob, CC BY licence and crop; the 39 evaluation people (both
    expressions) are exactly the issue's, each in its self-reported group, and no one is in two splits."""
    assert len(LONDON) == 204
    for r in LONDON:
        path = ROOT / r["file"]
        assert path.is_file() and jpeg_size(path) == tuple(r["size"]) and max(r["size"]) <= 800, r["file"]
        assert r["licence"].startswith("CC BY 4.0: DeBruine, L., & Jones, B. (2017)"), r["file"]
        assert r["source"]["repository"] == "debruine/webmorphR.stim", r["file"]
        assert re.fullmatch(r"[0-9a-f]{40}", r["source"]["blob"]) and len(r["crop"]) == 4, r["file"]
    splits = defaultdict(set)
    for r in LONDON:
        splits[r["subject"].split(",")[0]].add(r["split"])
    assert all(len(s) == 1 for s in splits.values()), "a person in two splits"
    evaluation = {(r["subject"].split()[3].rstrip(","), r["group"]) for r in LONDON if r["split"] == "evaluation"}
    expected = {(face, group) for group, faces in LONDON_EVALUATION.items() for face in faces.split()}
    assert evaluation == expected
    assert all(r["ethnicity"] == r["group"] for r in LONDON if r["split"] == "evaluation")
