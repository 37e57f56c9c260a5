"""Study: Model 2 on the rig (one flexible chassis body, detailed bolted joints).

The analogue of the thesis's Table 3 (first ten system modes) and the mode shapes at the
sensors. ``python studies/model2.py [--mesh production] [--damping adams-default] [--out DIR]``
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from model1 import run  # noqa: E402

if __name__ == "__main__":
    run(2)
