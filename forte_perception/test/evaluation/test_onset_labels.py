"""The CSV label file of slip onsets: reading, attaching to recordings, bad input."""
import numpy as np
import pytest

from forte_perception.evaluation.labelled_recordings import LabelledRecording
from forte_perception.evaluation.onset_labels import (
    LabelError,
    apply_onset_labels,
    load_onset_csv,
    recording_key,
    write_onset_csv,
)

GOOD = """# operator: test, video at 60 Hz
recording,onset_s,note

apple.npz,7.950,
apple.npz,4.213,"stick-slip, right finger"
jam_jar,
trials/jar2.npz , 0.5
"""


def write(tmp_path, text, name='labels.csv'):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_good_file(tmp_path):
    labels = load_onset_csv(write(tmp_path, GOOD))
    assert sorted(labels) == ['apple', 'jam_jar', 'jar2']
    np.testing.assert_array_equal(labels['apple'], [4.213, 7.95])   # sorted
    assert labels['jam_jar'].size == 0                                # labelled, no slip
    np.testing.assert_array_equal(labels['jar2'], [0.5])
    # columns in any order, the trailing empty onset cut off
    labels = load_onset_csv(write(tmp_path, 'onset_s,recording\n1.5,a\n'))
    np.testing.assert_array_equal(labels['a'], [1.5])
    assert load_onset_csv(write(tmp_path, 'recording,onset_s\nb\n'))['b'].size == 0
    assert recording_key('/x/y/apple.npz') == 'apple' == recording_key('apple')


@pytest.mark.parametrize('text, words', [
    ('', 'no header line'),
    ('# only a comment\n', 'no header line'),
    ('recording,onset\napple,1.0\n', "lacks column(s) onset_s"),
    ('name,onset_s\napple,1.0\n', 'lacks column(s) recording'),
    ('recording,onset_s\napple,soon\n', ":2: onset_s 'soon' is not a number"),
    ('recording,onset_s\napple,-0.1\n', ':2: onset_s must be a finite time >= 0 s'),
    ('recording,onset_s\napple,nan\n', ':2: onset_s must be a finite time >= 0 s'),
    ('recording,onset_s\napple,inf\n', ':2: onset_s must be a finite time >= 0 s'),
    ('# c\nrecording,onset_s\n,1.0\n', ':3: empty recording name'),
    ('onset_s,note,recording\n1.0,x\n', ':2: expected 3 cells, got 2'),
])
def test_bad_files_are_refused_with_the_line(tmp_path, text, words):
    path = write(tmp_path, text)
    with pytest.raises(LabelError) as error:
        load_onset_csv(path)
    assert words in str(error.value) and str(path) in str(error.value)


def test_unreadable_files(tmp_path):
    with pytest.raises(LabelError, match='cannot read'):
        load_onset_csv(tmp_path / 'missing.csv')
    path = tmp_path / 'binary.csv'
    path.write_bytes(b'\xff\xfe\x00bad')
    with pytest.raises(LabelError, match='cannot read'):
        load_onset_csv(path)


def test_apply_labels_to_recordings(tmp_path):
    rec = LabelledRecording(np.zeros((4000, 6)), 2000.0, np.array([5]), name='apple.npz')
    labelled = apply_onset_labels(rec, {'apple': np.array([0.5, 1.2345])})
    np.testing.assert_array_equal(labelled.onsets, [1000, 2469])
    assert rec.onsets.tolist() == [5]                                  # not changed
    with pytest.raises(LabelError, match="'apple' is not labelled"):
        apply_onset_labels(rec, {'pear': np.zeros(0)}, 'l.csv')
    with pytest.raises(LabelError, match='beyond the recording'):
        apply_onset_labels(rec, {'apple': np.array([2.5])})


def test_write_and_read_back(tmp_path):
    path = tmp_path / 'truth.csv'
    write_onset_csv(path, {'apple': np.array([1.0, 2.5]), 'jam_jar': np.zeros(0)},
                    'ground truth\nof the simulator')
    text = path.read_text()
    assert text.startswith('# ground truth\n# of the simulator\nrecording,onset_s\n')
    labels = load_onset_csv(path)
    np.testing.assert_array_equal(labels['apple'], [1.0, 2.5])
    assert labels['jam_jar'].size == 0
