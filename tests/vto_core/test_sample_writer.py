"""One sample's folder written apart and renamed into place: overlapping writers of one sample keep one folder, and a
shard clears only its own half-written samples."""

import pytest

from vto_core.dataset import SAMPLES_DIR, SampleWriter, finished_indices, remove_stale_temporaries, sample_name


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


def test_a_shard_removes_only_its_own_half_written_samples(tmp_path):
    samples = tmp_path / SAMPLES_DIR
    for index in (1, 5):  # a killed run's sample 1, and sample 5 being written by another shard right now
        SampleWriter(tmp_path, index)
    assert remove_stale_temporaries(tmp_path, range(0, 4)) == 1
    assert [p.name.split("-")[1] for p in samples.glob(".tmp-*")] == ["0000005"]
    assert remove_stale_temporaries(tmp_path) == 1  # no indices: every one (a run of the whole dataset)
    assert not list(samples.iterdir())
