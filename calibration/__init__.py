"""From pixels to millimetres in the plane of the mechanism, with a quality figure."""
