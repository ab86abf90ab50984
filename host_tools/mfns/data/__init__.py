"""The package's data. The XTCE dictionaries are not kept here: their one source is the
repository's contract/ folder (contract/README.md). The wheel's build step copies them into
mfns/data (host_tools/setup.py); an editable install reads contract/ itself."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

CONTRACT_DIR = Path(__file__).resolve().parents[3] / "contract"


def dictionary(name: str) -> Path:
    """The path of one dictionary (mfns_tm.xml, mfns_tc.xml, mfns_ground.xml): the wheel's
    copy when installed, else the repository's contract/ source."""
    packaged = Path(str(resources.files(__name__).joinpath(name)))
    return packaged if packaged.is_file() else CONTRACT_DIR / name
