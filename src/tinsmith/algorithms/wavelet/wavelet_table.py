"""Goebbels and Pohle-Fröhlich (2015)'s Table 1 and the land-use roles: the wavelet filter's constants, without its code.

The command line builds its options from these (choices, help) without
importing the filter (scipy and the quadtree's kernels).
"""

#: Table 1 of Goebbels and Pohle-Fröhlich (2015): thresholds (m) per coefficient level, coarsest first, for each kind of point.
TABLE_1 = {
    "class1": (0.0, 0.1, 0.1, 0.2, 0.2, 0.2, 0.3, 0.3, 0.4),
    "embankment": (0.1,) * 9,
    "class2": (0.0, 0.1, 0.2, 0.2, 0.3, 0.4, 0.5, 0.5, 0.5),
    "forest": (0.0, 0.1, 0.2, 0.2, 0.3, 20.0, 20.0, 20.0, 20.0),
}

#: The roles a land-use feature can have.
ROLES = ("water", "shoreline", "embankment", "bridge", "street", "forest")
