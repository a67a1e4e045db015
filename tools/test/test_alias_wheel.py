"""tools/alias_wheel.py: the metadata-only ``ament-index-python`` wheel of the launch kit setup."""
from __future__ import annotations

import base64
import hashlib
import importlib.metadata
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import alias_wheel  # noqa: E402

PROVIDER = 'ros-ament-index-python'


@pytest.fixture
def provider_version() -> str:
    try:
        return importlib.metadata.version(PROVIDER)
    except importlib.metadata.PackageNotFoundError:
        pytest.skip(f'{PROVIDER} (a ROS 2 Jazzy wheel) is not installed here')


def test_the_alias_requires_exactly_the_installed_provider(tmp_path, provider_version):
    wheel = alias_wheel.write_alias_wheel('ament-index-python', PROVIDER, tmp_path)
    assert wheel.name == f'ament_index_python-{provider_version}-py3-none-any.whl'
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        info = f'ament_index_python-{provider_version}.dist-info'
        assert sorted(names) == sorted(f'{info}/{n}' for n in ('METADATA', 'WHEEL', 'RECORD'))
        metadata = archive.read(f'{info}/METADATA').decode()
        assert 'Name: ament-index-python\n' in metadata
        assert f'Version: {provider_version}\n' in metadata
        assert f'Requires-Dist: {PROVIDER}=={provider_version}\n' in metadata
        for line in archive.read(f'{info}/RECORD').decode().splitlines():
            name, digest, size = line.split(',')
            if name.endswith('RECORD'):
                continue
            data = archive.read(name)
            expected = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b'=')
            assert digest == 'sha256=' + expected.decode() and int(size) == len(data)


def test_the_same_inputs_give_the_same_bytes(tmp_path, provider_version):
    first = alias_wheel.write_alias_wheel('ament-index-python', PROVIDER, tmp_path / 'a')
    second = alias_wheel.write_alias_wheel('ament-index-python', PROVIDER, tmp_path / 'b')
    assert first.read_bytes() == second.read_bytes()


def test_pip_installs_it_as_the_alias_distribution(tmp_path, provider_version):
    wheel = alias_wheel.write_alias_wheel('ament-index-python', PROVIDER, tmp_path / 'wheels')
    target = tmp_path / 'target'
    subprocess.run([sys.executable, '-m', 'pip', 'install', '-q', '--disable-pip-version-check',
                    '--no-deps', '--no-index', '--target', str(target), str(wheel)],
                   check=True, capture_output=True, timeout=120)
    found = list(importlib.metadata.distributions(name='ament-index-python', path=[str(target)]))
    assert [d.version for d in found] == [provider_version]
    assert found[0].requires == [f'{PROVIDER}=={provider_version}']
    assert not [p for p in target.iterdir() if not p.name.endswith('.dist-info')]


def test_a_missing_provider_is_a_clear_error(tmp_path):
    with pytest.raises(importlib.metadata.PackageNotFoundError):
        alias_wheel.write_alias_wheel('x-alias', 'no-such-distribution-here', tmp_path)
