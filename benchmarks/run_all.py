"""Run every benchmark in turn (`make bench`)."""

from benchmarks import (bench_batch, bench_dataset, bench_hair_colour, bench_hair_match, bench_locator, bench_mask_crop,
                        bench_match, bench_real_photos, bench_render, bench_training)


def main() -> None:
    """Each benchmark writes its own table under benchmarks/results/."""
    bench_render.main()
    bench_hair_match.main()
    bench_dataset.main()
    bench_training.main()
    bench_batch.main([])
    bench_match.main([])
    bench_mask_crop.main()
    bench_locator.main([])
    bench_real_photos.main([])
    bench_hair_colour.main([])


if __name__ == "__main__":
    main()
