# The names of tinsmith.algorithms: what type checkers and IDEs read, and what __init__.py imports on first use
# (lazy_loader).  Keep __all__ the same as the names below (tests/test_contract.py checks it).

from .compare import compare_methods
from .declaration import Declaration, Option
from .greedy.engine import GreedyEngine
from .grid.decimate import Decimation
from .grid.features import importance
from .grid.quadtree import QuadtreeHierarchy
from .grid.subsample import subsample_pyramid
from .registry import DEFAULT_METHOD, Method, declare, get_method, methods, register, simplify
from .urban.city import CityModel
from .urban.urban import BuildingTree, UrbanModel, building_tree

__all__ = [
    "DEFAULT_METHOD",
    "BuildingTree",
    "CityModel",
    "Decimation",
    "Declaration",
    "GreedyEngine",
    "Method",
    "Option",
    "QuadtreeHierarchy",
    "UrbanModel",
    "building_tree",
    "compare_methods",
    "declare",
    "get_method",
    "importance",
    "methods",
    "register",
    "simplify",
    "subsample_pyramid",
]
