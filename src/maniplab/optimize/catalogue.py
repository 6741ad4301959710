"""Catalogues of standard sizes a design variable may be chosen from.

``iso3320-bore`` and ``iso3320-rod`` are the cylinder bores and piston-rod diameters of ISO 3320
(fluid power cylinders, bore and rod diameters), in metres: a study names them with
``catalogue: iso3320-bore`` instead of listing the values.
"""

from __future__ import annotations

ISO3320_BORE_MM = (8, 10, 12, 16, 20, 25, 32, 40, 50, 63, 80, 90, 100, 110, 125, 140, 160, 180,
                   200, 220, 250, 280, 320, 360, 400, 450, 500)
"""ISO 3320 cylinder bores, mm (the preferred series and its second choices)."""

ISO3320_ROD_MM = (4, 5, 6, 8, 10, 12, 14, 16, 18, 20, 22, 25, 28, 32, 36, 40, 45, 50, 56, 63,
                  70, 80, 90, 100, 110, 125, 140, 160, 180, 200, 220, 250, 280, 320, 360)
"""ISO 3320 piston-rod diameters, mm."""

CATALOGUES: dict[str, tuple[float, ...]] = {
    "iso3320-bore": tuple(d / 1000.0 for d in ISO3320_BORE_MM),
    "iso3320-rod": tuple(d / 1000.0 for d in ISO3320_ROD_MM),
}
"""Catalogue name -> its values, in the spec's units (m)."""
