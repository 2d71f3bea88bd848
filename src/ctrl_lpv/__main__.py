"""``python -m ctrl_lpv``: the same as the ``ctrl-lpv`` command."""

import sys

from .cli import main

sys.exit(main())
