"""tools/run_tests.py judges each file by what pytest really did, including collecting nothing."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import run_tests  # noqa: E402


def write_tests(folder: Path, files: dict[str, str]) -> list[Path]:
    """Test files named after the keys with the values as their text, in a pytest rootdir."""
    (folder / 'pytest.ini').write_text('[pytest]\n')
    paths = []
    for name, text in files.items():
        path = folder / name
        path.write_text(text)
        paths.append(path)
    return paths


PASSING = 'def test_one():\n    assert 1 + 1 == 2\n'
FAILING = 'def test_one():\n    assert 1 + 1 == 3\n'
#: a test module whose tests were renamed away: pytest collects nothing and exits 5
NOTHING = 'def helper():\n    return 1\n'


@pytest.mark.parametrize(('text', 'code'), [(PASSING, 0), (FAILING, 1), (NOTHING, 1)])
def test_exit_code_follows_what_pytest_did(tmp_path, capsys, text, code):
    files = write_tests(tmp_path, {'test_good.py': PASSING, 'test_other.py': text})
    assert run_tests.main([], files=files, root=tmp_path) == code
    output = capsys.readouterr().out
    if text is NOTHING:
        assert 'test_other.py (exit 5: no test collected' in output


def test_a_selection_may_leave_a_file_empty(tmp_path):
    files = write_tests(tmp_path, {'test_good.py': PASSING,
                                   'test_other.py': 'def test_two():\n    pass\n'})
    assert run_tests.main(['-k', 'one'], files=files, root=tmp_path) == 0
    assert run_tests.main(['-k', 'nothing_matches'], files=files, root=tmp_path) == 0
    assert run_tests.main([], files=files, root=tmp_path) == 0
