"""``python -m skin_indent.cli``: the ``skin-indent`` command."""

import sys

from . import main

sys.exit(main())
