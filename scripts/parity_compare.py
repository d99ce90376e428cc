"""Compare two scripts/parity_capture.sh folders: match JSONs value for value, dataset files and images byte for byte.

    usage: python scripts/parity_compare.py BEFORE AFTER
"""
import hashlib, json, sys
from pathlib import Path

before, after = Path(sys.argv[1]), Path(sys.argv[2])
same = differ = 0
for a in sorted(before.rglob("*")):
    if a.is_dir() or a.suffix in (".stderr",) or a.name.endswith(".stdout") or a.name == "astronaut.png":
        continue
    b = after / a.relative_to(before)
    if not b.exists():
        print("MISSING", b); differ += 1; continue
    if a.suffix == ".json" and a.name.startswith("match_"):
        ja, jb = json.loads(a.read_text()), json.loads(b.read_text())
        ok = ja == jb
    elif a.name == "manifest.json" or a.name == "params.json":
        ja, jb = json.loads(a.read_text()), json.loads(b.read_text())
        for j in (ja, jb):  # the run's own paths and the code version differ between trees
            for k in ("out", "created", "code", "vto_core_version", "written"):
                j.pop(k, None)
        ok = ja == jb
        if not ok:
            print("DIFF", a.relative_to(before), {k: (ja.get(k), jb.get(k)) for k in set(ja) | set(jb) if ja.get(k) != jb.get(k)})
    else:
        ok = hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()
    if ok:
        same += 1
    else:
        differ += 1
        print("DIFF", a.relative_to(before))
# the notes each match printed
for a in sorted(before.glob("match_*.stderr")):
    b = after / a.name
    if a.read_text() != b.read_text():
        print("STDERR DIFF", a.name, a.read_text()[-200:], "||", b.read_text()[-200:]); differ += 1
print(f"{same} same, {differ} differ")
