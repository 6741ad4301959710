"""``python -m maniplab``: the same as the ``maniplab`` command."""

import sys

from maniplab.cli import main

sys.exit(main())
