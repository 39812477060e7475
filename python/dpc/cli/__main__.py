"""``python -m dpc.cli``: the same as the ``dpc`` command."""

import sys

from . import main

sys.exit(main())
