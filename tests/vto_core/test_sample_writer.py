"""One sample's folder written apart and renamed into place: overlapping writers of one sample keep one folder."""

import pytest

from vto_core.dataset import SAMPLES_DIR, SampleWriter, finished_indices, sample_name


def test_a_sample_committed_twice_keeps_the_first_folder_and_leaves_nothing_half_written(tmp_path):
    first, second = SampleWriter(tmp_path, 7), SampleWriter(tmp_path, 7)
    first.tmp = first.tmp.with_name(first.tmp.name + "-a")  # two processes: two temporary folders
    first.tmp.mkdir()
    first.params({"made_by": "first"})
    second.params({"made_by": "second"})
    first.commit()
    second.commit()  # an overlapping shard finished the same look: no error
    samples = tmp_path / SAMPLES_DIR
    assert sorted(p.name for p in samples.iterdir()) == [sample_name(7)]
    assert '"first"' in (samples / sample_name(7) / "params.json").read_text()
    assert finished_indices(tmp_path) == {7}


def test_a_commit_onto_something_that_is_not_a_sample_folder_still_fails(tmp_path):
    writer = SampleWriter(tmp_path, 3)
    writer.params({})
    writer.final.write_text("not a folder")
    with pytest.raises(OSError):
        writer.commit()
