"""``python -m exudyn_study.cli``: the console script."""

import sys

from exudyn_study.cli import main

sys.exit(main())
