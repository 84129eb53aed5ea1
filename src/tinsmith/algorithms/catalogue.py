"""What every built-in method is, without importing it: name, module, description, options, paper.

The registry (:mod:`.registry`) lists these records, so ``tinsmith methods``,
``--help`` and the option checks of every command need no method module, no
kernel and no numba; a method's module is imported when it is first run.
Each module's ``@register(name)`` takes its record from here.
"""

from __future__ import annotations

from .declaration import Declaration, Option

# Options quality and flood share (flood is quality's refinement under a time-step floor).
ANGLE_BOUND = Option("min_angle", float, 30.0, "degrees: every plan-view angle at least this, except at smaller input "
                     "angles of the outline or breaklines (at most 33: beyond, refinement can cascade)", minimum=0.0,
                     exclusive_min=True, maximum=33.0)
GRADING = Option("grading", float, None, "a triangle is refined while its area exceeds this factor squared times a "
                 "neighbour's (tested when it is made)", minimum=1.0)
MAX_AREA = Option("max_area", float, None, "largest plan-view triangle area (world units squared)", minimum=0.0,
                  exclusive_min=True)
IMPROVE = Option("improve", int, 30, "passes of mesh improvement after refinement: vertices removed and moved while "
                 "every bound still holds (0: refinement alone)", minimum=0)

DECLARED = [
    Declaration(
        "grid",
        module="tinsmith.algorithms.grid.grid",
        description="full resolution: every valid cell a vertex, two triangles per cell",
        stop_rules=False,
        paper="Goebbels and Pohle-Fröhlich (2015), section 2 (diagonal rule)",
    ),
    Declaration(
        "greedy",
        module="tinsmith.algorithms.greedy.greedy",
        description="greedy insertion: Delaunay TIN refined at the worst cell (or input point) until the error bound holds",
        options=[
            Option("breaklines", object, None, "polylines kept as mesh edges (world coordinates; CLI: a vector file)",
                   kind="lines"),
            Option("control_points", object, None, "points always kept as vertices (world coordinates; CLI: a vector file)",
                   kind="points"),
            Option("max_edge", object, "auto",
                   "triangles with a longer edge are cut from the outline ('auto': 12 x the median edge; "
                   "CLI: a length, 'auto' or 'none')", input="points"),
            Option("duplicates", str, "lowest", "the height kept where points share an x-y",
                   choices=("lowest", "highest", "mean"), input="points"),
            Option("holes", object, None, "polygons left open (world coordinates; CLI: a vector file)",
                   kind="polygons", input="points"),
            Option("flat", object, None,
                   "polygons meshed flat at their shore's level, a lake or river (CLI: a vector file)",
                   kind="polygons", input="points"),
            Option("workers", int, None,
                   "threads. A grid: tiles meshed with shared seams under the same bound (1: one piece), by "
                   "default every core for a grid of at least 4,000,000 cells with a max_error stop, else 1. "
                   "A point cloud with an error bound alone: tiles on threads as a survey's (1: one piece), by default "
                   "every core for a cloud of at least 1,000,000 points; with constraints or another stop: one piece, "
                   "its TIN triangulated in strips on the threads (default every core)",
                   minimum=1),
        ],
        input="elevation",
        paper="Duan et al. (2016), section 3.2 (HFPR); the Salt Lake City thesis, section 2.4; "
              "Garland & Heckbert 1995 on scattered points",
    ),
    Declaration(
        "subsample",
        module="tinsmith.algorithms.grid.subsample",
        description="regular subsampling: every step-th row and column (and the last), triangulated",
        options=[
            Option(
                "step", int, None,
                "keep every step-th row and column (cells); without it the stop rule chooses, else 2",
                minimum=1,
            ),
        ],
        paper="the Salt Lake City thesis, section 2.1",
    ),
    Declaration(
        "features",
        module="tinsmith.algorithms.grid.features",
        description="feature points: the most important cells (Sobel gradient or curvature) and the border, Delaunay",
        options=[
            Option("measure", str, "sobel", "importance of a cell", choices=("sobel", "curvature")),
        ],
        paper="the Salt Lake City thesis, sections 2.3 and 3.1.1",
    ),
    Declaration(
        "quadtree",
        module="tinsmith.algorithms.grid.quadtree",
        description="crack-free quadtree (RTIN, as Martini) with a strict error bound at every cell",
        options=[
            Option(
                "strict", bool, True,
                "bound the error at every cell (False: Martini's midpoint estimate, its meshes exactly)",
            ),
            Option(
                "diagonal", str, "alternate",
                "alternate: the RTIN's diagonals (Martini); "
                "rule: squares cut by Goebbels and Pohle-Fröhlich (2015)'s formula 1, fans where needed",
                choices=("alternate", "rule"),
            ),
        ],
        paper="the Salt Lake City thesis, section 2.2; Goebbels and Pohle-Fröhlich (2015), section 2",
    ),
    Declaration(
        "decimate",
        module="tinsmith.algorithms.grid.decimate",
        description="quadric edge collapse from the full-resolution mesh, outline kept, no fold-overs",
        input="surface",
        paper="the Salt Lake City thesis, section 2.2 (Garland and Heckbert 1997)",
    ),
    Declaration(
        "cvt",
        module="tinsmith.algorithms.cvt.cvt",
        description="curvature CVT (cCVT): quasi-uniform, terrain-adaptive sites moved to the centroids of their cells",
        stop_rules=("max_vertices",),
        exact_budget=True,
        options=[
            Option("ratio", float, 0.01, "share of the valid cells kept as vertices when max_vertices is not given",
                   minimum=0.0, exclusive_min=True, maximum=1.0),
            Option("density_gamma", float, 1.0, "exponent on |mean curvature| in the density (0: uniform sites; at "
                   "most 8)", minimum=0.0, maximum=8.0),
            Option("density_floor", float, 0.1, "lowest density, as a share of the mean |curvature|, so flat land keeps sites",
                   minimum=0.0, exclusive_min=True),
            Option("anchor_fraction", float, 0.0,
                   "share of the budget taken from greedy insertion's first insertions and held still",
                   minimum=0.0, maximum=0.95),
            Option("tol", float, 1e-4, "stop when the relative change of the CVT energy is below this",
                   minimum=0.0),
            Option("max_iter", int, 200, "most Lloyd iterations", minimum=0),
            Option("acceleration", str, "lbfgs",
                   "speed-up of the Lloyd iteration: Anderson mixing, L-BFGS on the energy, or plain Lloyd",
                   choices=("anderson", "lbfgs", "lloyd")),
            Option("seed", int, 0, "seed of the initial sites", minimum=0),
            Option("breaklines", object, None, "polylines kept as mesh edges (world coordinates; CLI: a vector file)",
                   kind="lines"),
            Option("control_points", object, None, "points always kept as vertices (world coordinates; CLI: a vector file)",
                   kind="points"),
        ],
        paper="Duan et al. (2016), Algorithm 2 (Lloyd on dual cells, Meyer et al. 2003 curvature)",
    ),
    Declaration(
        "remesh",
        module="tinsmith.algorithms.remesh.remesh",
        description="isotropic remeshing to exactly max_vertices: error diffusion, then weighted CVT in parameter space",
        input="surface",
        stop_rules=("max_vertices",),
        exact_budget=True,
        options=[
            Option("n_vertices", int, None, "the exact number of vertices of the result", minimum=3,
                   replaced_by="max_vertices"),
            Option("density", str, "uniform", "where vertices go: uniform over the surface, or denser where it bends",
                   choices=("uniform", "curvature")),
            Option("gamma", float, 1.0, "transfer exponent of the curvature density (at most 8: beyond, every vertex "
                   "crowds onto the sharpest feature)", minimum=0.0, maximum=8.0),
            Option("smooth", int, 0, "rounds of low-pass filtering of the density", minimum=0),
            Option("gradation", float, 0.1, "the sample spacing grows by at most this much per unit of distance",
                   minimum=0.0, exclusive_min=True),
            Option("feature_angle", float, 60.0, "degrees: sharper edges and turns are features and corners, kept",
                   minimum=0.0, maximum=180.0),
            Option("iterations", int, 40, "weighted Lloyd iterations at most", minimum=0),
            Option("parameterization", str, "auto", "xy for terrain, conformal (LSCM) for other disk-like meshes",
                   choices=("auto", "xy", "conformal")),
            Option("seed", int, 0, "seed of the Sobol points of the first sampling", minimum=0),
            Option("breaklines", object, None, "lines that stay edges: x-y polylines in world coordinates (terrain)",
                   kind="lines"),
        ],
        paper="Alliez et al. (2003)",
    ),
    Declaration(
        "reconstruct",
        module="tinsmith.algorithms.reconstruct.reconstruct",
        description="projection-based reconstruction of a point cloud: every vertex an input point, heightfield "
                    "(one point per dexel) or general (any surface) mode",
        input="points",
        stop_rules=False,
        options=[
            Option("mode", str, "auto", "heightfield (layered clouds), general (walls, overhangs) or auto",
                   choices=("auto", "heightfield", "general")),
            Option("mu", float, 2.5, "general mode: neighbours within mu times the distance to the second-nearest "
                   "point", minimum=1.0, exclusive_min=True),
            Option("max_angle", float, 120.0, "general mode, degrees: wider gaps between neighbours stay open",
                   minimum=60.0, maximum=180.0),
            Option("min_angle", float, 10.0, "degrees: for reconstruct, neighbours making a smaller angle are "
                   "dropped (0: off); for quality, the plan-view angle bound", minimum=0.0, maximum=59.0),
            Option("dexel_size", float, None, "dexel width, world units (heightfield mode: the level of "
                   "simplification; default twice the mean spacing)", minimum=0.0, exclusive_min=True),
            Option("view", str, "any", "general mode: above (an airborne scan: no face grows turned down, so "
                   "roofs do not fold over; then the gaps are closed) or any", choices=("any", "above")),
            Option("workers", int, None, "threads for general mode: clouds of 200,000 points or more are meshed in "
                   "strips, the same mesh on any number; default every core", minimum=1),
        ],
        legacy={"classes": "keep the classes when reading (tinsmith.read(path, classes=...)) or with "
                           "cloud.filter_classes(...)"},
        paper="Gopi and Krishnan (2002) (Gopi and Krishnan 2002)",
    ),
    Declaration(
        "wavelet",
        module="tinsmith.algorithms.wavelet.wavelet",
        description="spline and Haar-wavelet filtering steered by land use, then the quadtree within max_error of "
                    "the filtered heights (Goebbels and Pohle-Fröhlich 2015; default 0.2); also a pre-filter of any method",
        stop_rules=("max_error",),
        options=[
            Option("epsilon", float, None, "accuracy of the quadtree against the filtered heights (z units)",
                   minimum=0.0, exclusive_min=True, replaced_by="max_error"),
            Option("landuse", object, None, "land-use polygons: a vector file, or a LandUse (CLI: --landuse FILE)"),
            Option("roles", object, None, "key -> role of the land-use features (CLI: --role KEY:ROLE)"),
            Option("attribute", str, None, "the usage column the role keys name"),
            Option("spline_iterations", object, "auto", "coarsenings of the spline approximation, or auto"),
            Option("delta", float, 4.0, "class 2: points whose height departs from the spline by more (z units)",
                   minimum=0.0),
            Option("thresholds", object, None, "rows of Table 1 replaced (CLI: --thresholds ROW=t0,t1,...)"),
            Option("variant", object, 4, "the Haar low pass: formula 4, formula 3, or None (unfiltered detail)"),
            Option("window", int, 9, "side, in grid points, of the square that makes a point near a feature",
                   minimum=1),
            Option("bridge_extension", float, 2.0, "grow bridges by this much (world units)", minimum=0.0),
            Option("replace_tolerance", float, 0.3, "low-pass heights replace spline heights only where they differ "
                   "by more (z units)", minimum=0.0),
            Option("replace", str, "soft", "hard: the paper's switch; soft: the difference shrunk by the tolerance",
                   choices=("soft", "hard")),
            Option("flatten_water", bool, True, "flatten each water body to its mean height"),
        ],
        legacy={"return_filter": "the filtered heights and the classes are tinsmith.wavelet_filter(...)"},
        paper="Goebbels and Pohle-Fröhlich (2015)",
    ),
    Declaration(
        "urban",
        module="tinsmith.algorithms.urban.city",
        description="a city model of a surface model: buildings found (or footprints), flat or planar roofs, the "
                    "ground, in one crack-free mesh (tinsmith urban has every option)",
        stop_rules=False,
        options=[
            Option("footprints", object, None, "building outlines, one building each, instead of finding them "
                   "(world coordinates; CLI: a vector file)", kind="polygons"),
            Option("roofs", str, "flat", "flat roofs (LoD 1.2) or planar facets (LoD 2-like)",
                   choices=("flat", "planes")),
            Option("roof_height", str, "p70", "statistic of a flat roof: median, max or pNN"),
            Option("min_height", float, None, "least building height above the ground (z units; default 2.5 m)",
                   minimum=0.0, exclusive_min=True),
            Option("min_area", float, None, "smallest building (world units squared; default 10 m2)",
                   minimum=0.0, exclusive_min=True),
            Option("ground_window", float, 60.0, "window of the ground estimate (world units): wider than the "
                   "buildings", minimum=0.0, exclusive_min=True),
            Option("ground_error", float, None, "vertical error of the ground between buildings (z units; default "
                   "0.5 m)", minimum=0.0, exclusive_min=True),
            Option("solid", bool, False, "close the model into a watertight volume: sides down to a base and a "
                   "bottom"),
            Option("margin", float, 0.0, "grow the domain by this much on every side (world units), the ground held "
                   "at its edge height", minimum=0.0),
        ],
        paper="the Salt Lake City thesis, chapter 4 (building outlines); METHODS.md (city models)",
        deprecated="the city model is tinsmith.city(dsm, ...).mesh (`tinsmith city` on the command line); "
                   "the Salt Lake City thesis' block model is method 'blocks'",
    ),
    Declaration(
        "blocks",
        module="tinsmith.algorithms.urban.urban",
        description="the Salt Lake City thesis' block model of a surface model: a tree of building outlines "
                    "from height thresholds, flat roofs, vertical walls and the ground in one crack-free surface",
        stop_rules=False,
        options=[
            Option("lod", int, 4, "slices of the band of one standard deviation around the mean height", minimum=1),
            Option("noise_factor", int, 10, "regions of fewer grid points are dropped (0 keeps all)", minimum=0),
            Option("min_area", float, None, "regions of less area are dropped (world units squared)", minimum=0.0),
            Option("min_width", float, None, "regions narrower than this are dropped (world units)", minimum=0.0),
            Option("relative_to_ground", bool, False, "thresholds on the height above the ground"),
            Option("ground", object, None, "the ground (a DTM on the grid of the input; default a grey-scale "
                   "opening of it; CLI: a raster file)", kind="raster"),
            Option("ground_window", float, 60.0, "window of the estimated ground (world units): wider than the "
                   "buildings", minimum=0.0, exclusive_min=True),
            Option("simplify_tolerance", float, 0.0, "outlines simplified between the points where three faces meet "
                   "(world units)", minimum=0.0),
            Option("ground_error", float, None, "vertical error of the ground between buildings (z units; default: "
                   "flat between the outlines)", minimum=0.0),
            Option("max_roughness", float, None, "regions rougher than this (median, z units) are dropped: tree "
                   "crowns", minimum=0.0),
            Option("mask", object, None, "the cells that may be buildings: an (H, W) bool array, or a raster whose "
                   "non-zero cells are (CLI: a raster file)", kind="raster"),
        ],
        paper="the Salt Lake City thesis, chapter 4",
    ),
    Declaration(
        "quality",
        module="tinsmith.algorithms.quality.quality",
        description="Delaunay refinement: the exact error bound of greedy insertion and a minimum plan-view angle "
                    "(a mesh for 2-D solvers)",
        options=[
            ANGLE_BOUND,
            MAX_AREA,
            GRADING,
            IMPROVE,
            Option("regions", object, None, "areas with their own largest triangle area, kept apart by edges and "
                   "named in the output: (polygon, max_area[, name]) items (world units; CLI: a vector file with "
                   "fields max_area and name)", kind="regions"),
            Option("breaklines", object, None, "polylines kept as mesh edges (world coordinates; CLI: a vector file)",
                   kind="lines"),
            Option("control_points", object, None, "points always kept as vertices (world coordinates; CLI: a vector "
                   "file)", kind="points"),
        ],
        paper="METHODS.md section 12: Ruppert 1995, Shewchuk 2002, Üngör 2004; Duan et al. (2016), section 3.2 (the error scan)",
    ),
    Declaration(
        "flood",
        module="tinsmith.algorithms.flood.flood",
        description="quality refinement sized for an explicit shallow-water solver: a time-step floor from the "
                    "expected flow, the streams as breaklines, the outline cut into inflow, outflow and walls",
        options=[
            ANGLE_BOUND,
            Option("time_step", object, "auto",
                   "seconds: no triangle is refined for the error bound below the inradius that keeps its CFL step "
                   "(inradius over the expected wave speed) at this ('auto': a uniform mesh's of the count the bound "
                   "needs; CLI: seconds or 'auto')"),
            Option("depth", object, None, "the expected water depth, a raster on the DEM's grid in metres (default: "
                   "the normal depth of steady flow under rain; CLI: a raster file)", kind="raster"),
            Option("rain", float, 100.0, "mm/h: the rain rate of the expected flow", minimum=0.0, exclusive_min=True),
            Option("manning", float, 0.03, "Manning's n of the expected flow", minimum=0.0, exclusive_min=True),
            Option("streams", object, None, "stream lines kept as breaklines and cutting the outline (world "
                   "coordinates; CLI: --streams FILE; default: derived from the DEM's flow)", kind="lines"),
            Option("stream_area", float, None, "contributing area (world units squared) of the derived streams "
                   "(default 1000 cells)", minimum=0.0, exclusive_min=True),
            Option("max_area", float, None, "largest plan-view triangle area (world units squared; default: "
                   "twice the triangle of a uniform mesh of the count the bound needs)", minimum=0.0,
                   exclusive_min=True),
            GRADING,
            IMPROVE,
            Option("breaklines", object, None, "polylines kept as mesh edges (world coordinates; CLI: a vector file)",
                   kind="lines"),
            Option("control_points", object, None, "points always kept as vertices (world coordinates; CLI: a vector "
                   "file)", kind="points"),
        ],
        paper="Courant, Friedrichs & Lewy (1928); Manning's formula; Leopold & Maddock (1953); the quality "
              "method's Ruppert 1995, Shewchuk 2002, Üngör 2004",
    ),
]

#: The methods ``tinsmith tile`` runs in seamless tiles (a shared seam contract).  greedy
#: refines from the seam vertices directly; the others choose the tile's interior vertices,
#: which greedy insertion then triangulates with the seam vertices and tops up to the bound.
TILE_METHODS = ("greedy", "quadtree", "cvt")
