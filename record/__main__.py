"""``python -m aiogenomix.record``: the same as ``aiogenomix-record``."""

import sys

from ._command import main

sys.exit(main())
