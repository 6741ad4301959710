"""maniplab's installed version, for cache keys and the headers of generated files.

Read from the package metadata here rather than imported from the package root, so the model
package does not depend on ``maniplab/__init__.py`` (which imports this package).
"""

from __future__ import annotations

import functools
from importlib.metadata import PackageNotFoundError, version


@functools.cache
def package_version() -> str:
    """The installed maniplab's version, or "0+unknown" in a source tree without installation."""
    try:
        return version("maniplab")
    except PackageNotFoundError:
        return "0+unknown"
