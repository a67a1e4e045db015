"""Write a metadata-only wheel that gives an installed distribution a second name.

    python tools/alias_wheel.py ALIAS PROVIDER OUTDIR      (prints the wheel's path)

Why: the launch kit's ``launch_ros`` wheel (built from upstream's setup.py) requires the
distribution ``ament-index-python``; the package index has no distribution of that name,
and the module ``ament_index_python`` comes with the ROS 2 Jazzy wheels as
``ros-ament-index-python``. pip then reports "launch-ros 0.26.6 requires ament-index-python,
which is not installed" although the module is there. The wheel written here is the
distribution ``ALIAS`` at the installed version of ``PROVIDER``, with no files of its own and
the single requirement ``PROVIDER==<that version>``: pip's view of the environment then
matches what is importable (``pip check`` clean), and the alias cannot outlive or differ
from what provides the module.

Run it with the Python of the environment that has ``PROVIDER`` installed. The wheel is
byte-identical for the same inputs.
"""
from __future__ import annotations

import base64
import hashlib
import importlib.metadata
import re
import sys
import zipfile
from pathlib import Path

#: Fixed timestamp of the zip entries, so that the same inputs give the same bytes.
ZIP_TIME = (2024, 1, 1, 0, 0, 0)


def _record_hash(data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b'=')
    return 'sha256=' + digest.decode()


def write_alias_wheel(alias: str, provider: str, folder: Path) -> Path:
    """Write ``<alias>-<version>-py3-none-any.whl`` into ``folder`` and return its path.

    Raises
    ------
    importlib.metadata.PackageNotFoundError
        If ``provider`` is not installed in this interpreter's environment.
    """
    version = importlib.metadata.version(provider)
    stem = re.sub(r'[-_.]+', '_', alias).lower()
    dist_info = f'{stem}-{version}.dist-info'
    files = {
        f'{dist_info}/METADATA': (
            'Metadata-Version: 2.1\n'
            f'Name: {alias}\n'
            f'Version: {version}\n'
            f'Summary: The name {alias} for {provider} (tools/alias_wheel.py of FORTE)\n'
            f'Requires-Dist: {provider}=={version}\n'),
        f'{dist_info}/WHEEL': (
            'Wheel-Version: 1.0\n'
            'Generator: forte-tools-alias-wheel\n'
            'Root-Is-Purelib: true\n'
            'Tag: py3-none-any\n'),
    }
    record = ''.join(f'{name},{_record_hash(text.encode())},{len(text.encode())}\n'
                     for name, text in files.items()) + f'{dist_info}/RECORD,,\n'
    files[f'{dist_info}/RECORD'] = record
    folder.mkdir(parents=True, exist_ok=True)
    wheel = folder / f'{stem}-{version}-py3-none-any.whl'
    with zipfile.ZipFile(wheel, 'w', zipfile.ZIP_DEFLATED) as archive:
        for name, text in files.items():
            entry = zipfile.ZipInfo(name, date_time=ZIP_TIME)
            entry.external_attr = 0o644 << 16
            archive.writestr(entry, text, zipfile.ZIP_DEFLATED)
    return wheel


if __name__ == '__main__':
    if len(sys.argv) != 4:
        sys.exit(__doc__.strip().splitlines()[2].strip())
    print(write_alias_wheel(sys.argv[1], sys.argv[2], Path(sys.argv[3])))
