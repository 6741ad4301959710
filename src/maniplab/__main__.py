"""``python -m maniplab``: the same as the ``maniplab`` command.

The current folder is not searched for modules: the package's ``__init__`` takes it off
``sys.path`` before importing anything (it runs before this module), so a ``yaml.py`` or a plugin
module lying next to a spec is never run; name plugin modules with ``--plugin``.
"""

import sys

from maniplab.cli import main

sys.exit(main())
