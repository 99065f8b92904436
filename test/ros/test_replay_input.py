"""``ballscrew-twin replay`` on a damaged bag: it plays what it can and says what is wrong in
one warning line each, never a traceback."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

SAMPLES = Path(__file__).resolve().parents[2] / "data" / "samples"


def test_replay_of_a_bag_whose_metadata_is_not_utf8(tmp_path: Path) -> None:
    bag = tmp_path / "healthy"
    shutil.copytree(SAMPLES / "healthy", bag)
    meta = bag / "metadata.yaml"
    meta.write_bytes(meta.read_bytes().replace(b"ros_distro", b"ros\xe9distro", 1))
    script = Path(sys.executable).parent / "ballscrew-twin"
    result = subprocess.run(
        [str(script), "replay", str(bag), "--rate", "0"],
        capture_output=True,
        text=True,
        env=dict(os.environ),
        stdin=subprocess.DEVNULL,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    warnings = [line for line in result.stderr.splitlines() if "metadata.yaml" in line]
    offset = meta.read_bytes().index(0xE9)
    assert warnings == [
        f"replay: warning: {meta}: not UTF-8 (byte 0xe9 at offset {offset}); ignored, read "
        "healthy.mcap directly"
    ]
    assert "published 6600 messages" in result.stdout  # every message of the sample
