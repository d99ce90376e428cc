"""How long finding the hair takes on a 1-megapixel portrait, and where the time goes.

    python -m benchmarks.bench_hair_speed

Each portrait of benchmarks/photos with a face, resized to about a megapixel (bench_photo_forms.megapixel): its face
read once, then the hair locator (vto_core.photo.hair_locator, the face mesh apart) timed REPEATS times after a
warm-up, the portraits in turn (the machine's speed drifts); the median per portrait. Then cProfile over one more
pass of all of them: the functions that take the most time of their own. Writes benchmarks/results/hair_speed.md.
"""

from __future__ import annotations

import cProfile
import json
import pstats
import time

import numpy as np

from benchmarks.bench_photo_forms import megapixel
from benchmarks.bench_real_photos import MODELS, PHOTOS
from benchmarks.common import write_table

REPEATS = 7
GOAL_MS = 60.0  # the issue's: finding the hair stays within this on a 1-megapixel portrait
PROFILED = 8  # functions listed


def locate(locator, image: np.ndarray, face) -> None:
    """The hair of `face` in `image`, a refusal counted as a finding (it costs the same work)."""
    from vto_core.errors import VtoError

    try:
        locator.locate(image, face)
    except VtoError:
        pass


def main() -> None:
    from vto_core.photo.face_reader import FaceReader
    from vto_core.photo.hair_locator import HairLocator

    reader = FaceReader(MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx")
    locator = HairLocator(MODELS / "person_segmenter.onnx")
    jobs = []
    for record in (r for r in json.loads(PHOTOS.read_text()) if r.get("faces")):
        image = megapixel(record)
        jobs.append((record["subject"], image, reader.read(image)))
    for _, image, face in jobs:
        locate(locator, image, face)
    spans = np.zeros((REPEATS, len(jobs)))
    for repeat in range(REPEATS):  # the portraits in turn, so that the machine's speed drifting spares none
        for i, (_, image, face) in enumerate(jobs):
            started = time.perf_counter()
            locate(locator, image, face)
            spans[repeat, i] = 1000 * (time.perf_counter() - started)
    medians = np.median(spans, axis=0).tolist()
    rows = [[subject, f"{image.shape[1]}x{image.shape[0]}", f"{ms:.1f}"]
            for (subject, image, _), ms in zip(jobs, medians)]
    profile = cProfile.Profile()
    profile.enable()
    for _, image, face in jobs:
        locate(locator, image, face)
    profile.disable()
    stats = pstats.Stats(profile).stats
    own = sorted(((v[2], f"{k[2]} ({k[0].rsplit('/', 1)[-1]}:{k[1]})") for k, v in stats.items()), reverse=True)
    where = "; ".join(f"{name} {1000 * seconds / len(jobs):.1f} ms" for seconds, name in own[:PROFILED])
    notes = (f"Median over the portraits {np.median(medians):.1f} ms, largest {max(medians):.1f} (goal {GOAL_MS:.0f} "
             f"ms). Per portrait, the time a function takes of its own (cProfile, one pass): {where}.")
    write_table("hair_speed", f"Finding the hair on a 1-megapixel portrait (ms, median of {REPEATS})",
                ["portrait", "size", "ms"], rows, notes)


if __name__ == "__main__":
    main()
